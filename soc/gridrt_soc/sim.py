"""The Verilator target: ``GridrtSoC`` on LiteX's ``SimPlatform``.

The UART is LiteX's stream model (``RS232PHYModel``: a byte per clock, no baud rate) and
reaches the host through our simulation module ``serial2pty`` (soc/sim_modules/), which
opens a pseudo-terminal, prints ``serial2pty: /dev/pts/N`` and applies flow control both
ways: nothing is dropped when the host is slow to read or quick to write.

``prepare`` generates the gateware and csr.json, then compiles the Verilated simulator
only when its inputs changed (a hash of every generated source, the RTL, the simulation
modules and the Verilator version, kept in ``sim.stamp``): a new ROM image is read at start
from ``*.init`` files and needs no rebuild. The simulator is ``<gateware>/obj_dir/Vsim``,
run from ``<gateware>`` (it reads ``sim_config.js`` and ``modules/`` there).
"""

import hashlib
import shutil
import subprocess
import time
from pathlib import Path

from litex.build.generic_platform import Pins, Subsignal
from litex.build.io import CRG
from litex.build.sim import SimPlatform
from litex.build.sim.config import SimConfig
from litex.soc.cores.uart import RS232PHYModel
from litex.soc.integration.builder import Builder

from . import board_files
from .soc import SYS_CLK_FREQ, GridrtSoC

SIM_MODULES = Path(__file__).resolve().parents[1] / "sim_modules"

_io = [
    ("sys_clk", 0, Pins(1)),
    ("sys_rst", 0, Pins(1)),
    (
        "serial",
        0,
        Subsignal("source_valid", Pins(1)),
        Subsignal("source_ready", Pins(1)),
        Subsignal("source_data", Pins(8)),
        Subsignal("sink_valid", Pins(1)),
        Subsignal("sink_ready", Pins(1)),
        Subsignal("sink_data", Pins(8)),
    ),
]


def make_soc(rtl_dir, rom_words=()):
    platform = SimPlatform("SIM", _io)
    soc = GridrtSoC(platform, RS232PHYModel(platform.request("serial")), rtl_dir, rom_words)
    # Clock from the `clocker` module; reset for the first cycle (power-on).
    soc.crg = CRG(platform.request("sys_clk"))
    return soc


def _stamp(gateware, platform, verilator):
    h = hashlib.sha256()
    h.update(verilator.encode())
    generated = sorted(p for p in gateware.iterdir() if p.suffix in (".v", ".sv", ".cpp", ".h", ".mak", ".sh"))
    sources = sorted({Path(f) if Path(f).is_absolute() else gateware / f for f, *_ in platform.sources})
    module_sources = sorted(p for p in SIM_MODULES.rglob("*") if p.is_file())
    for path in generated + sources + module_sources:
        h.update(path.name.encode())
        h.update(path.read_bytes())
    return h.hexdigest()


def prepare(build_dir, rtl_dir, rom_words, board_files_mode, jobs=2):
    """Generates and (if needed) compiles the simulator; returns its gateware directory."""
    build_dir = Path(build_dir).resolve()
    soc = make_soc(rtl_dir, rom_words)
    # The C modules are compiled in the build tree: LiteX writes a variables.mak next to them.
    mods = build_dir / "sim_modules"
    if mods.exists():
        shutil.rmtree(mods)
    shutil.copytree(SIM_MODULES, mods)

    sim_config = SimConfig()
    sim_config.add_clocker("sys_clk", freq_hz=SYS_CLK_FREQ)
    sim_config.add_module("serial2pty", "serial")

    builder = Builder(
        soc,
        output_dir=str(build_dir),
        compile_software=False,
        csr_json=str(build_dir / "csr.json"),
        csr_csv=str(build_dir / "csr.csv"),
    )
    builder.build(
        sim_config=sim_config,
        build=True,
        run=False,
        opt_level="O2",
        jobs=jobs,
        interactive=False,
        extra_mods=["serial2pty"],
        extra_mods_path=str(mods),
    )
    board_files.apply(board_files.render(build_dir / "csr.json", soc), board_files_mode)

    gateware = Path(builder.gateware_dir)
    verilator = subprocess.run(["verilator", "--version"], capture_output=True, text=True, check=True).stdout.strip()
    stamp = _stamp(gateware, soc.platform, verilator)
    stamp_file = gateware / "sim.stamp"
    exe = gateware / "obj_dir" / "Vsim"
    if exe.exists() and stamp_file.exists() and stamp_file.read_text() == stamp:
        print(f"sim: simulator up to date ({exe})")
    else:
        print(f"sim: compiling the simulator with {verilator} (a few minutes on 2 cores)", flush=True)
        start = time.monotonic()
        stamp_file.unlink(missing_ok=True)
        # LiteX's script rebuilds obj_dir/ only; stale simulation modules would survive.
        shutil.rmtree(gateware / "modules", ignore_errors=True)
        log = gateware / "build_sim.log"
        with open(log, "w") as out:
            r = subprocess.run(["bash", "build_sim.sh"], cwd=gateware, stdout=out, stderr=subprocess.STDOUT)
        if r.returncode != 0 or not exe.exists():
            tail = "".join(log.read_text().splitlines(True)[-40:])
            raise SystemExit(f"sim: building the simulator failed ({r.returncode}); log {log}:\n{tail}")
        stamp_file.write_text(stamp)
        print(f"sim: compiled {exe} in {time.monotonic() - start:.0f} s")
    return gateware
