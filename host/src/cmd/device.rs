//! `gridrt device`: the simulated board on a serial port.

use std::io::ErrorKind;
use std::time::Duration;

use gridrt_host::serial;

use super::common::ModelOptions;

/// Run the simulated board (firmware device loop + co-processor model) on a serial port.
///
/// The board the loopback simulator plays in-process for `render --sim`, but reached
/// through a real serial line, so that `gridrt render --port` can be tried without hardware:
///
///   socat -d -d pty,raw,echo=0,link=/tmp/gridrt-dev pty,raw,echo=0,link=/tmp/gridrt-host &
///   gridrt device --port /tmp/gridrt-dev &
///   gridrt render --port /tmp/gridrt-host --scene tests/scenes/bun_zipper_res4.obj --out a.png
///
/// Runs until the port closes (socat exits when the client closes its end) or Ctrl-C.
#[derive(Debug, clap::Parser)]
pub struct Cmd {
    /// Serial port to serve on.
    #[arg(short = 'p', long, value_name = "PATH")]
    port: String,
    /// Baud rate.
    #[arg(short = 'b', long, default_value_t = 115_200, value_name = "BAUD")]
    baud: u32,
    /// Processing elements of the simulated co-processor.
    #[arg(long, default_value_t = 4, value_name = "N")]
    pes: u16,
    /// Words of memory per PE [default: the simulator's 1048576; with --coproc rtl: 16384].
    #[arg(long, value_name = "W")]
    pe_mem_words: Option<u32>,
    #[clap(flatten)]
    model: ModelOptions,
}

impl Cmd {
    /// Runs the command.
    pub fn run(self) -> anyhow::Result<()> {
        let config = self.model.sim_config(self.pes, self.pe_mem_words)?;
        gridrt_loopback::prepare(&config).map_err(anyhow::Error::msg)?;
        let port = serial::open(&self.port, self.baud, Duration::from_millis(200))?;
        eprintln!(
            "gridrt device: simulated board ({} PEs x {} words) on {}; Ctrl-C to stop",
            config.pe_count, config.pe_mem_words, self.port
        );
        match gridrt_loopback::run_on_port(port, config) {
            Ok(()) => Ok(()),
            // A pty whose other side went away reads as EOF or EIO.
            Err(e) if e.kind() == ErrorKind::UnexpectedEof || e.raw_os_error() == Some(5) => {
                eprintln!("gridrt device: {} closed", self.port);
                Ok(())
            }
            Err(e) => Err(anyhow::Error::new(e).context(format!("serving on {}", self.port))),
        }
    }
}
