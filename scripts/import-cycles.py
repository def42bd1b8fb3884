#!/usr/bin/env python3
"""Lists pairs of source files that import each other (ARCHITECTURE.md: "no two files import
each other"), in every crate of the workspace.

An import is a `use` item (`pub use` re-exports included) whose path starts with `crate::`,
`super::`, `self::` or the name of a child module; it points at the file that defines the deepest module on that path. Imports inside
inline modules (`mod tests { use super::*; }`) resolve from that inline module. A file's own
items do not count. Exit status 1 when a pair is found.

    python3 scripts/import-cycles.py [CRATE_DIR ...]     # default: every crate with a src/
"""

import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def module_files(src: Path):
    """{module path tuple: file} for one crate's src/ (lib.rs or main.rs is the root)."""
    mods = {}
    for f in src.rglob("*.rs"):
        rel = f.relative_to(src).with_suffix("").parts
        if rel in (("lib",), ("main",)):
            key = ()
        elif rel[-1] == "mod":
            key = rel[:-1]
        elif len(rel) >= 1 and rel[0] == "bin":
            continue
        else:
            key = rel
        # lib.rs wins over main.rs for the crate root.
        if key == () and () in mods and rel == ("main",):
            continue
        mods[key] = f
    return mods


def strip_comments(text: str) -> str:
    text = re.sub(r"/\*.*?\*/", "", text, flags=re.S)
    return re.sub(r"//[^\n]*", "", text)


def expand_tree(tree: str):
    """`a::{b, c::{d, e}}` -> ['a::b', 'a::c::d', 'a::c::e'] (aliases dropped)."""
    tree = tree.strip()
    i = tree.find("{")
    if i < 0:
        return [re.sub(r"\s+as\s+\w+$", "", tree).strip()]
    prefix, body = tree[:i], tree[i + 1 : tree.rfind("}")]
    parts, depth, cur = [], 0, ""
    for ch in body:
        if ch == "{":
            depth += 1
        elif ch == "}":
            depth -= 1
        if ch == "," and depth == 0:
            parts.append(cur)
            cur = ""
        else:
            cur += ch
    parts.append(cur)
    out = []
    for p in parts:
        if p.strip():
            out += [prefix + q if q != "self" else prefix.rstrip(":") for q in expand_tree(p)]
    return out


def imports(f: Path, own: tuple, mods: dict):
    """Absolute module paths (tuples) that file `f`, module `own`, imports."""
    text = strip_comments(f.read_text())
    found = []
    # Inline module nesting by brace depth: stack of (name, depth at which it opened).
    stack, depth, pos = [], 0, 0
    token = re.compile(r"\bmod\s+(\w+)\s*\{|\buse\s+([^;]+);|\{|\}")
    for m in token.finditer(text):
        if m.group(1):
            depth += 1
            stack.append((m.group(1), depth))
        elif m.group(2) is not None:
            here = own + tuple(n for n, _ in stack)
            for path in expand_tree(m.group(2)):
                segs = [s for s in path.replace(" ", "").split("::") if s]
                if not segs:
                    continue
                if segs[0] == "crate":
                    base, segs = (), segs[1:]
                elif segs[0] in ("super", "self"):
                    base = here
                    while segs and segs[0] in ("super", "self"):
                        if segs[0] == "super":
                            base = base[:-1]
                        segs = segs[1:]
                elif here + (segs[0],) in mods:
                    base = here  # a child module, named without `self::`
                else:
                    continue
                found.append(base + tuple(s for s in segs if s != "*"))
        elif m.group(0) == "{":
            depth += 1
        else:
            if stack and stack[-1][1] == depth:
                stack.pop()
            depth -= 1
    return found


def owner(path: tuple, mods: dict):
    """The file defining the deepest module on `path`."""
    for n in range(len(path), -1, -1):
        if path[:n] in mods:
            return mods[path[:n]]
    return None


def main(argv):
    crates = [Path(a).resolve() for a in argv] or sorted(p.parent for p in ROOT.rglob("src") if (p.parent / "Cargo.toml").exists() and "target" not in p.parts)
    bad = 0
    for crate in crates:
        mods = module_files(crate / "src")
        edges = set()
        for key, f in mods.items():
            for path in imports(f, key, mods):
                g = owner(path, mods)
                if g is not None and g != f:
                    edges.add((f, g))
        for a, b in sorted(edges):
            if (b, a) in edges and str(a) < str(b):
                print(f"{a.relative_to(ROOT)} <-> {b.relative_to(ROOT)}")
                bad += 1
    if bad:
        print(f"{bad} pair(s) of files import each other")
        return 1
    print(f"no two files import each other ({len(crates)} crates)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
