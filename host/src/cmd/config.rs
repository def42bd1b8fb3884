//! The optional configuration file `gridrt.toml`: the board a user talks to most.
//!
//! ```toml
//! port = "/dev/ttyUSB0"   # serial port of the board
//! baud = 921600           # its line rate
//! board = 2               # the board id it must report (0 simulator, 1 qemu-virt, 2 FPGA SoC, 3 LiteX)
//! ```
//!
//! Looked for in the current folder, else in `$XDG_CONFIG_HOME/gridrt/gridrt.toml`, else in
//! `~/.config/gridrt/gridrt.toml`. A value given on the command line wins, then the
//! environment (`GRIDRT_PORT`, `GRIDRT_BAUD`), then this file, then the built-in default.

use std::path::{Path, PathBuf};

use anyhow::Context;

/// The file's name.
pub const FILE_NAME: &str = "gridrt.toml";

/// What `--help` says about the file (shown after the options of the commands that use it).
pub const HELP: &str = "\
Configuration: port, baud rate and board may also come from the environment (GRIDRT_PORT,
GRIDRT_BAUD) or from a file gridrt.toml in the current folder, else in
$XDG_CONFIG_HOME/gridrt/gridrt.toml (~/.config/gridrt/gridrt.toml), e.g.

    port = \"/dev/ttyUSB0\"
    baud = 921600
    board = 2

A command-line flag wins over the environment, the environment over the file, the file over
the built-in default.";

/// The file's keys (all optional).
#[derive(Debug, Default, Clone, PartialEq, Eq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Config {
    /// Serial port of the board.
    pub port: Option<String>,
    /// Baud rate.
    pub baud: Option<u32>,
    /// Board id the device must report in its answer to Hello.
    pub board: Option<u8>,
}

/// The file in use: `./gridrt.toml`, else the user's configuration folder's; `None` if
/// neither exists.
pub fn find() -> Option<PathBuf> {
    let here = PathBuf::from(FILE_NAME);
    if here.is_file() {
        return Some(here);
    }
    let base = std::env::var_os("XDG_CONFIG_HOME")
        .filter(|v| !v.is_empty())
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").filter(|v| !v.is_empty()).map(|h| Path::new(&h).join(".config")))?;
    let user = base.join("gridrt").join(FILE_NAME);
    user.is_file().then_some(user)
}

/// Reads `path`.
pub fn read(path: &Path) -> anyhow::Result<Config> {
    let text = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    toml::from_str(&text).map_err(|e| anyhow::anyhow!("{}: {}", path.display(), e.message()))
}

/// The configuration in force: the file [`find`] finds, or none.
pub fn load() -> anyhow::Result<Config> {
    match find() {
        Some(path) => read(&path),
        None => Ok(Config::default()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_parse_and_unknown_ones_are_refused() {
        let c: Config = toml::from_str("port = \"/dev/ttyUSB1\"\nbaud = 921600\nboard = 2\n").unwrap();
        assert_eq!(c, Config { port: Some("/dev/ttyUSB1".into()), baud: Some(921_600), board: Some(2) });
        assert!(toml::from_str::<Config>("prot = \"x\"").is_err());
    }
}
