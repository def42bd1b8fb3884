#!/usr/bin/env python3
"""Tests of scripts/import-cycles.py (run by .ci/run):

- the code as it was at commit f10b1a6 had two import circles, `host`'s camera <-> scene
  (`Bounds` one way through scene/mod.rs's re-export, `RenderSettings`/`Camera` the other)
  and `xtask`'s rtl <-> rtl_synth (a path written out in code one way, a `use` the other):
  the script must report both;
- small synthetic crates: one without a circle (re-exports, `super::`, a test module that
  imports back) reports none; one whose circle goes through a `pub use` reports it.

    python3 scripts/test_import_cycles.py
"""

import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SCRIPT = ROOT / "scripts" / "import-cycles.py"
BEFORE = "f10b1a6"


def run(*crates):
    p = subprocess.run([sys.executable, str(SCRIPT), *map(str, crates)], capture_output=True, text=True)
    return p.returncode, p.stdout + p.stderr


def git_files(commit, folder):
    out = subprocess.run(
        ["git", "ls-tree", "-r", "--name-only", commit, "--", folder],
        cwd=ROOT, capture_output=True, text=True, check=True,
    ).stdout
    return [line for line in out.splitlines() if line.endswith(".rs")]


def copy_at(commit, paths, dest: Path):
    for path in paths:
        text = subprocess.run(
            ["git", "show", f"{commit}:{path}"], cwd=ROOT, capture_output=True, text=True, check=True
        ).stdout
        out = dest / path
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(text)


def write(dest: Path, files: dict):
    for path, text in files.items():
        out = dest / path
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(text)


failures = []


def check(what, ok, output):
    print(f"{'ok' if ok else 'FAILED'}: {what}")
    if not ok:
        print("    " + output.replace("\n", "\n    "))
        failures.append(what)


def test_circles_at_f10b1a6(tmp: Path):
    host = ["host/src/lib.rs", "host/src/camera.rs"] + git_files(BEFORE, "host/src/scene")
    xtask = [f"xtask/src/{f}.rs" for f in ("main", "rtl", "rtl_synth")]
    copy_at(BEFORE, host + xtask, tmp)
    status, out = run(tmp / "host", tmp / "xtask")
    check("f10b1a6: exit status 1", status == 1, out)
    check("f10b1a6: host camera <-> scene", "circle crate::camera <-> crate::scene" in out, out)
    check("f10b1a6: xtask rtl <-> rtl_synth", "circle crate::rtl <-> crate::rtl_synth" in out, out)
    check("f10b1a6: two circles", "2 import circle(s)" in out, out)


def test_synthetic_without_circle(tmp: Path):
    write(tmp / "clean", {
        "src/lib.rs": "mod geom;\npub mod scene;\nmod view;\npub use geom::Bounds;\n",
        "src/geom.rs": "pub struct Bounds;\n",
        "src/view.rs": "use crate::Bounds;\nuse crate::scene::Scene;\npub fn fit(_: &Bounds, _: &Scene) {}\n",
        "src/scene/mod.rs": "mod model;\npub use model::Scene;\n#[cfg(test)]\nmod tests;\n",
        "src/scene/model.rs": (
            "use super::super::geom::Bounds;\n"
            "pub struct Scene { pub b: Bounds }\n"
            "#[cfg(test)]\nmod tests {\n    use crate::view::fit;\n}\n"
        ),
        "src/scene/tests.rs": "use super::*;\nuse crate::view::fit;\n",
    })
    status, out = run(tmp / "clean")
    check("synthetic crate without a circle: none reported", status == 0 and "no import circles" in out, out)


def test_synthetic_circle_through_reexport(tmp: Path):
    write(tmp / "loop", {
        "src/lib.rs": "mod a;\nmod b;\n",
        "src/a/mod.rs": "mod inner;\npub use inner::Thing;\npub struct Other;\n",
        "src/a/inner.rs": "pub struct Thing(crate::b::Gadget);\n",
        "src/b.rs": "use crate::a::Thing;\npub struct Gadget;\npub fn f(_: Thing) {}\n",
    })
    status, out = run(tmp / "loop")
    check("synthetic circle through a re-export: reported",
          status == 1 and "circle crate::a <-> crate::b" in out and "src/b.rs uses crate::a::Thing" in out, out)


def main():
    for test in (test_circles_at_f10b1a6, test_synthetic_without_circle, test_synthetic_circle_through_reexport):
        with tempfile.TemporaryDirectory() as tmp:
            test(Path(tmp))
    if failures:
        print(f"{len(failures)} check(s) failed")
        return 1
    print("import-cycles.py: all checks passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
