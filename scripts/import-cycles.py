#!/usr/bin/env python3
"""Lists import circles between modules (ARCHITECTURE.md: "no two files import each other";
inside each row of the module table a module uses only those before it), in every crate of
the workspace.

A file's module path comes from its place under src/: `src/a/b.rs` and `src/a/b/mod.rs` are
`crate::a::b`, `lib.rs` (else `main.rs`) is the crate root. An import is any path that starts
with `crate::`, `super::` or `self::` (in a `use` item, `pub use` re-exports included, or
written out in code, `crate::a::B::new()`), and a `use` path that starts with the name of a
child module. Imports inside inline modules (`mod x { use super::*; }`) resolve from that
inline module; `#[cfg(test)]` modules (inline or files) are tests, not the code, and are left
out. A path points at the module that defines its item: a name a module brings in
with `use` (a re-export, or a private import a child reaches through `super::`) is followed to
where it is defined, so `crate::scene::Bounds` with `pub use mesh::Bounds` in `scene/mod.rs`
points at `crate::scene::mesh`.

Two checks:
- siblings: an import from module `p::a::…` to `p::b::…` makes `p::a` use `p::b`; a circle
  among the children of one module (`camera` -> `scene` -> `camera`, whichever files inside
  `scene/` make it) is reported with the imports that close it;
- ancestors: a module and one of its ancestors that import each other (a `mod.rs` using an
  item of a child that uses an item defined in that `mod.rs`).

Exit status 1 when anything is found.

    python3 scripts/import-cycles.py [CRATE_DIR ...]     # default: every crate with a src/
"""

import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def module_files(src: Path):
    """{module path tuple: file} for one crate's src/ (lib.rs or main.rs is the root)."""
    mods = {}
    for f in sorted(src.rglob("*.rs")):
        rel = f.relative_to(src).with_suffix("").parts
        if rel in (("lib",), ("main",)):
            key = ()
        elif rel[0] == "bin":
            continue
        elif rel[-1] == "mod":
            key = rel[:-1]
        else:
            key = rel
        # lib.rs wins over main.rs for the crate root.
        if key == () and () in mods and rel == ("main",):
            continue
        mods[key] = f
    return mods


NOISE = re.compile(
    r"//[^\n]*"  # line comment
    r"|/\*.*?\*/"  # block comment
    r"|\br(#*)\".*?\"\1"  # raw string
    r"|b?\"(?:\\.|[^\"\\])*\""  # string
    r"|b?'(?:\\.|[^\\'])'",  # char literal (not a lifetime)
    re.S,
)


def strip_noise(text: str) -> str:
    """Comments, strings and char literals blanked out."""
    return NOISE.sub(" ", text)


def expand_tree(tree: str):
    """`a::{b, c::{d, e as f}}` -> [('a::b', 'b'), ('a::c::d', 'd'), ('a::c::e', 'f')]:
    each path with the name it binds (`*` for a glob)."""
    tree = tree.strip()
    i = tree.find("{")
    if i < 0:
        m = re.match(r"^(.*?)\s+as\s+(\w+)$", tree, flags=re.S)
        path, alias = (m.group(1), m.group(2)) if m else (tree, None)
        path = re.sub(r"\s+", "", path)
        return [(path, alias or path.split("::")[-1])]
    prefix, body = re.sub(r"\s+", "", tree[:i]), tree[i + 1 : tree.rfind("}")]
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
        if not p.strip():
            continue
        for path, name in expand_tree(p):
            if path == "self":
                full = prefix.rstrip(":")
                out.append((full, name if name != "self" else full.split("::")[-1]))
            else:
                out.append((prefix + path, name))
    return out


def absolute(segs, here, mods, use_item):
    """A path's segments made absolute from module `here`, or None when it leaves the crate."""
    segs = [s for s in segs if s]
    if not segs:
        return None
    if segs[0] == "crate":
        return tuple(segs[1:])
    if segs[0] in ("super", "self"):
        base = here
        while segs and segs[0] in ("super", "self"):
            if segs[0] == "super":
                base = base[:-1]
            segs = segs[1:]
        return base + tuple(segs)
    if use_item and here + (segs[0],) in mods:
        return here + tuple(segs)  # a child module, named without `self::`
    return None


CODE_PATH = re.compile(r"(?<![\w:])(?:crate|super|self)(?:\s*::\s*(?:\w+|\*))+")


def scan(f: Path, own: tuple, mods: dict):
    """(imports, uses) of file `f`, module `own`: imports are (from-module, absolute path);
    uses are {module: {name: absolute path}} for the names its `use` items bind (globs under
    the name `*`, a list)."""
    text = strip_noise(f.read_text())
    found, uses = [], {}
    stack, depth = [], 0  # inline modules: (name, brace depth at which it opened, cfg(test))
    token = re.compile(r"(#\[cfg\(test\)\]\s*(?:#\[[^\]]*\]\s*)*)?\bmod\s+(\w+)\s*\{|\buse\s+([^;]+);|\{|\}|" + CODE_PATH.pattern)
    for m in token.finditer(text):
        here = own + tuple(n for n, _, _ in stack)
        testing = any(t for _, _, t in stack)
        if m.group(2):
            depth += 1
            stack.append((m.group(2), depth, bool(m.group(1))))
        elif m.group(0) in ("{", "}"):
            if m.group(0) == "{":
                depth += 1
            else:
                if stack and stack[-1][1] == depth:
                    stack.pop()
                depth -= 1
        elif testing:
            continue  # a `#[cfg(test)]` module's imports are not the code's
        elif m.group(3) is not None:
            table = uses.setdefault(here, {})
            for path, name in expand_tree(m.group(3)):
                segs = path.split("::")
                glob = segs[-1] == "*"
                target = absolute(segs[:-1] if glob else segs, here, mods, True)
                if target is None:
                    continue
                found.append((here, target))
                if glob:
                    table.setdefault("*", []).append(target)
                elif name != "_":
                    table[name] = target
        else:
            segs = [s for s in re.sub(r"\s+", "", m.group(0)).split("::") if s != "*"]
            target = absolute(segs, here, mods, False)
            if target is not None:
                found.append((here, target))
    return found, uses


def defines(f: Path, name: str) -> bool:
    text = strip_noise(f.read_text())
    kinds = r"(?:fn|struct|enum|trait|type|const|static|union|mod|macro_rules!)"
    return re.search(rf"\b{kinds}\s+{re.escape(name)}\b", text) is not None


def module_of(path: tuple, mods: dict):
    """The deepest file module on `path` and the segments after it."""
    for n in range(len(path), -1, -1):
        if path[:n] in mods:
            return path[:n], path[n:]
    return (), path


def resolve(path: tuple, mods: dict, uses: dict, seen=None):
    """The file module that defines the item `path` names, following `use` bindings."""
    seen = seen or set()
    if path in seen:
        return module_of(path, mods)[0]
    seen.add(path)
    mod, rest = module_of(path, mods)
    if not rest:
        return mod
    table = uses.get(mod, {})
    if rest[0] in table:
        return resolve(table[rest[0]] + rest[1:], mods, uses, seen)
    if not defines(mods[mod], rest[0]):
        for g in table.get("*", []):
            gmod, grest = module_of(g + rest, mods)
            if grest and (defines(mods[gmod], grest[0]) or grest[0] in uses.get(gmod, {})):
                return resolve(g + rest, mods, uses, seen)
    return mod


def circles(edges):
    """Strongly connected components of more than one node (Tarjan)."""
    graph = {}
    for a, b in edges:
        graph.setdefault(a, set()).add(b)
        graph.setdefault(b, set())
    index, low, on, stack, out, n = {}, {}, set(), [], [], [0]

    def visit(v):
        index[v] = low[v] = n[0]
        n[0] += 1
        stack.append(v)
        on.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def name(mod: tuple) -> str:
    return "::".join(("crate",) + mod)


def check_crate(crate: Path, show=print):
    """The circles of one crate, printed; returns how many."""
    src = crate / "src"
    mods = module_files(src)
    # Files of `#[cfg(test)] mod x;` modules (and their children) test, they are not the code.
    tests = set()
    for key, f in mods.items():
        for m in re.finditer(r"#\[cfg\(test\)\]\s*(?:#\[[^\]]*\]\s*)*mod\s+(\w+)\s*;", strip_noise(f.read_text())):
            tests.add(key + (m.group(1),))
    raw, uses = [], {}
    for key, f in mods.items():
        if any(key[: len(t)] == t for t in tests):
            continue
        found, u = scan(f, key, mods)
        raw += [(key, target, f) for _, target in found]
        uses.update(u)
    # (from module, to module) -> [(file, imported path)] for the report.
    edges = {}
    for key, target, f in raw:
        to = resolve(target, mods, uses)
        if to != key:
            edges.setdefault((key, to), []).append((f, target))

    def where(a, b):
        f, path = sorted(edges[(a, b)], key=lambda e: (str(e[0]), e[1]))[0]
        more = len({e[0] for e in edges[(a, b)]}) - 1
        tail = f" and {more} more file(s)" if more > 0 else ""
        return f"{f.relative_to(crate)} uses {name(path)}{tail}"

    bad = 0
    # Siblings: an edge lifted to the children of the deepest common ancestor.
    lifted = {}
    for a, b in edges:
        n = 0
        while n < min(len(a), len(b)) and a[n] == b[n]:
            n += 1
        if n == len(a) or n == len(b):
            continue  # one is an ancestor of the other: the second check
        lifted.setdefault((a[: n + 1], b[: n + 1]), []).append((a, b))
    for comp in circles(lifted):
        members = set(comp)
        inner = sorted(e for e in lifted if e[0] in members and e[1] in members)
        show(f"{crate.relative_to(ROOT) if crate.is_relative_to(ROOT) else crate}: circle "
             + " <-> ".join(name(c) for c in comp))
        for pair in inner:
            show(f"    {name(pair[0])} -> {name(pair[1])}: {where(*sorted(lifted[pair])[0])}")
        bad += 1
    # Ancestors: a module and its ancestor import each other.
    for a, b in sorted(edges):
        if len(a) < len(b) and b[: len(a)] == a and (b, a) in edges:
            show(f"{crate.relative_to(ROOT) if crate.is_relative_to(ROOT) else crate}: circle "
                 f"{name(a)} <-> {name(b)}")
            show(f"    {where(a, b)}")
            show(f"    {where(b, a)}")
            bad += 1
    return bad


def main(argv):
    crates = [Path(a).resolve() for a in argv] or sorted(
        p.parent for p in ROOT.rglob("src") if (p.parent / "Cargo.toml").exists() and "target" not in p.parts
    )
    bad = sum(check_crate(c) for c in crates)
    if bad:
        print(f"{bad} import circle(s)")
        return 1
    print(f"no import circles ({len(crates)} crates)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
