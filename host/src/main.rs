//! `gridrt`: the host command-line tool. Only parses arguments and dispatches; every
//! subcommand lives in its own file under `cmd/`.

mod cmd;

use clap::Parser;

/// Host tool of the GridRT FPGA ray tracer: builds uniform-grid scenes, uploads them to a
/// device (or the loopback simulator), assembles rendered frames, compares them with an f64
/// reference, and benchmarks the native ray path.
#[derive(Debug, Parser)]
#[command(name = "gridrt", version, propagate_version = true, after_help = cmd::config::HELP)]
struct Cli {
    /// Progress lines also name the device's last message (protocol detail).
    #[arg(short = 'v', long, global = true)]
    verbose: bool,
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, clap::Subcommand)]
enum Command {
    /// Render one frame on a device or the loopback simulator and write a PNG.
    ///
    /// Loads the scene, builds the uniform grid (GridRT Eq. 6.1) for the device's PEs,
    /// uploads the scene image, requests one frame and assembles it from the pixel spans
    /// (every pixel and the image CRC are checked). With --sim an in-process loopback
    /// simulator plays the board and is reached only through its UART byte stream. With
    /// --reference the frame is compared with the independent f64 reference renderer.
    /// The frame size, the outputs and the port are checked before anything is sent.
    #[command(after_help = cmd::config::HELP)]
    Render(cmd::render::Cmd),
    /// Benchmarks: `rays` (native primary-ray path), `accuracy` (kernels × number formats,
    /// time vs error), `skip` (pipeline skips, interpolation), `link` (UART), `frame` (the
    /// whole frame on the modelled board), `splat` (point splats).
    Bench(cmd::bench::Cmd),
    /// Flash an application ELF through the device's bootloader, verify it and start it.
    #[command(after_help = cmd::config::HELP)]
    Flash(cmd::flash::Cmd),
    /// Print what a board sends on its own: text lines and decoded frames (banner, errors).
    Monitor(cmd::monitor::Cmd),
    /// List serial ports.
    Ports(cmd::ports::Cmd),
    /// Run the simulated board on a serial port (try `render --port` over a socat pty pair).
    Device(cmd::device::Cmd),
    /// Print a shell completion script (bash, zsh, fish, elvish, powershell).
    Completions(cmd::completions::Cmd),
}

/// The error's chain on one line: `a: b: c`, a cause whose text the line already holds
/// (an OS error quoted by its context) left out, line breaks folded.
fn one_line(e: &anyhow::Error) -> String {
    let mut line = String::new();
    for cause in e.chain() {
        let text = cause.to_string().split_whitespace().collect::<Vec<_>>().join(" ");
        if text.is_empty() || line.contains(&text) {
            continue;
        }
        if !line.is_empty() {
            line.push_str(": ");
        }
        line.push_str(&text);
    }
    line
}

/// A clap error on one line (usage and the `--help` hint dropped); help and version as clap
/// prints them.
fn clap_exit(e: clap::Error) -> ! {
    use clap::error::ErrorKind;
    if matches!(e.kind(), ErrorKind::DisplayHelp | ErrorKind::DisplayVersion)
        || e.kind() == ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
    {
        e.exit();
    }
    let text = e.to_string();
    let body: Vec<&str> = text
        .lines()
        .take_while(|l| !l.starts_with("Usage:") && !l.starts_with("For more information"))
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .collect();
    let line = body.join(" ");
    let line = line.strip_prefix("error: ").unwrap_or(&line);
    eprintln!("error: {line} (see --help)");
    std::process::exit(e.exit_code());
}

fn main() -> std::process::ExitCode {
    let cli = Cli::try_parse().unwrap_or_else(|e| clap_exit(e));
    cmd::progress::set_verbose(cli.verbose);
    let result = match cli.command {
        Command::Render(cmd) => cmd.run(),
        Command::Bench(cmd) => cmd.run(),
        Command::Flash(cmd) => cmd.run(),
        Command::Monitor(cmd) => cmd.run(),
        Command::Ports(cmd) => cmd.run(),
        Command::Device(cmd) => cmd.run(),
        Command::Completions(cmd) => {
            use clap::CommandFactory;
            cmd.run(&mut Cli::command())
        }
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", one_line(&e));
            std::process::ExitCode::FAILURE
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cli_definition_is_consistent() {
        use clap::CommandFactory;
        Cli::command().debug_assert();
    }

    #[test]
    fn render_requires_a_connection() {
        use cmd::config::Config;
        let parse = |args: &[&str]| -> cmd::render::Cmd {
            match Cli::try_parse_from(["gridrt", "render", "--scene", "a.obj", "--out", "a.png"].iter().chain(args))
                .unwrap()
                .command
            {
                Command::Render(c) => c,
                c => panic!("{c:?}"),
            }
        };
        let none = Config::default();
        let file = Config { port: Some("/dev/ttyCFG".into()), baud: Some(921_600), board: None };
        // No connection anywhere.
        assert!(parse(&[]).port.clone().resolve_with(&none, None).is_err());
        // --sim and an explicit --port.
        assert!(parse(&["--sim", "--port", "x"]).port.clone().resolve_with(&none, None).is_err());
        // --sim wins over GRIDRT_PORT.
        let mut p = parse(&["--sim", "--port", "x"]).port.clone();
        p.resolve_with(&file, Some("x".into())).unwrap();
        assert!(p.port.is_empty());
        // The file fills what the flags leave out; a flag wins.
        let mut p = parse(&[]).port.clone();
        p.resolve_with(&file, None).unwrap();
        assert_eq!((p.port.as_slice(), p.baud()), (&["/dev/ttyCFG".to_string()][..], 921_600));
        let mut p = parse(&["-p", "/dev/ttyA", "-b", "9600"]).port.clone();
        p.resolve_with(&file, None).unwrap();
        assert_eq!((p.port.as_slice(), p.baud()), (&["/dev/ttyA".to_string()][..], 9600));
        let mut p = parse(&["--sim"]).port.clone();
        p.resolve_with(&none, None).unwrap();
        assert_eq!(p.baud(), 115_200);
        let ok = Cli::try_parse_from([
            "gridrt",
            "render",
            "--sim",
            "--scene",
            "a.obj",
            "--out",
            "a.png",
            "--pes",
            "8",
            "--reference",
        ]);
        assert!(ok.is_ok(), "{ok:?}");
        assert!(Cli::try_parse_from([
            "gridrt", "render", "--sim", "--scene", "a.obj", "--out", "a.png", "--pes", "256"
        ])
        .is_err());
        assert!(Cli::try_parse_from([
            "gridrt", "render", "--sim", "--scene", "a.obj", "--out", "a.png", "--grid-m", "0"
        ])
        .is_err());
        assert!(Cli::try_parse_from([
            "gridrt", "bench", "rays", "--scene", "a.obj", "--width", "64", "--height", "64", "--json", "b.json"
        ])
        .is_ok());
    }

    #[test]
    fn render_takes_several_boards_and_link_options() {
        let parse = |args: &[&str]| {
            Cli::try_parse_from(["gridrt", "render", "--scene", "a.obj", "--out", "a.png"].iter().chain(args))
        };
        assert!(parse(&["--port", "/dev/ttyUSB0", "--port", "/dev/ttyUSB1", "--encoding", "rle"]).is_ok());
        assert!(parse(&["--sim-devices", "2", "--sim-paced", "--baud", "921600", "--band-rows", "8"]).is_ok());
        assert!(parse(&["--sim-devices", "0"]).is_err());
        assert!(parse(&["--sim", "--width", "0"]).is_err());
        assert!(parse(&["--sim", "--width", "4097"]).is_err());
        assert!(parse(&["--sim", "-W", "4096", "-H", "1"]).is_ok());
        assert!(parse(&["--sim", "--encoding", "jpeg"]).is_err());
        assert!(Cli::try_parse_from(["gridrt", "bench", "link", "--out-dir", "o", "--devices", "1,2"]).is_ok());
        assert!(Cli::try_parse_from(["gridrt", "bench", "link", "--out", "o"]).is_ok(), "--out: hidden alias");
        assert!(Cli::try_parse_from(["gridrt", "bench", "frame", "--scene", "a.obj", "--json", "f.json"]).is_ok());
        assert!(Cli::try_parse_from(["gridrt", "bench", "frame", "--scene", "a.obj"]).is_err());
        assert!(Cli::try_parse_from([
            "gridrt",
            "bench",
            "frame",
            "--scene",
            "a.obj",
            "--json",
            "f.json",
            "--encoding",
            "jpeg"
        ])
        .is_err());
    }
}

#[cfg(test)]
mod error_line_tests {
    use super::one_line;

    #[test]
    fn the_chain_is_one_line_without_repeats() {
        let os = std::io::Error::from_raw_os_error(2);
        let e = anyhow::Error::new(os).context("opening serial port /dev/x: No such file or directory (os error 2)");
        let e = e.context("connecting\nto the board");
        assert_eq!(
            one_line(&e),
            "connecting to the board: opening serial port /dev/x: No such file or directory (os error 2)"
        );
    }
}
