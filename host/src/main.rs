//! `gridrt`: the host command-line tool. Only parses arguments and dispatches; every
//! subcommand lives in its own file under `cmd/`.

mod cmd;

use clap::Parser;

/// Host tool of the GridRT FPGA ray tracer: builds uniform-grid scenes, uploads them to a
/// device (or the loopback simulator), assembles rendered frames, compares them with an f64
/// reference, and benchmarks the native ray path.
#[derive(Debug, Parser)]
#[command(name = "gridrt", version, propagate_version = true)]
struct Cli {
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
    Render(cmd::render::Cmd),
    /// Benchmarks: `rays` (native primary-ray path, single thread), `accuracy` (kernels ×
    /// number formats, time vs error), `skip` (pipeline skips, interpolation), `link` (UART),
    /// `frame` (the whole frame on the modelled board).
    Bench(cmd::bench::Cmd),
    /// Flash an application ELF through the device's bootloader, verify it and start it.
    Flash(cmd::flash::Cmd),
    /// List serial ports.
    Ports(cmd::ports::Cmd),
    /// Run the simulated board on a serial port (try `render --port` over a socat pty pair).
    Device(cmd::device::Cmd),
}

fn main() -> anyhow::Result<()> {
    match Cli::parse().command {
        Command::Render(cmd) => cmd.run(),
        Command::Bench(cmd) => cmd.run(),
        Command::Flash(cmd) => cmd.run(),
        Command::Ports(cmd) => cmd.run(),
        Command::Device(cmd) => cmd.run(),
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
        assert!(Cli::try_parse_from(["gridrt", "render", "--scene", "a.obj", "--out", "a.png"]).is_err());
        assert!(Cli::try_parse_from([
            "gridrt", "render", "--sim", "--port", "x", "--scene", "a.obj", "--out", "a.png"
        ])
        .is_err());
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
        assert!(parse(&["--sim-devices", "2", "--port", "x"]).is_err());
        assert!(parse(&["--sim", "--encoding", "jpeg"]).is_err());
        assert!(Cli::try_parse_from(["gridrt", "bench", "link", "--out", "o", "--devices", "1,2"]).is_ok());
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
