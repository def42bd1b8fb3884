#!/usr/bin/env python3
"""Lists pairs of Rust source files that import each other, and fails when there is one.

Usage: scripts/check-import-circles.py CRATE_DIR...   (e.g. shared coproc firmware host)

A file imports another when it names an item through a path that resolves into it:
`use crate::a::b`, `crate::a::b::f()`, `super::x`, `self::x`, a relative `use child::x`,
and `$crate::` paths in macros. A parent's `mod child;` is a declaration, not an import;
a `pub use child::X` re-export is one. Paths resolve to the longest module prefix that is a
file of the crate (src/a.rs, src/a/mod.rs), so an item re-exported by a parent counts as the
parent's. Inline `mod name { ... }` blocks (tests) are followed for `super::`. Text-based:
comments are stripped, macros other than paths are not expanded.
"""
import os, re, sys

def modpath(src, f):
    rel = os.path.relpath(f, src)[:-3].split(os.sep)
    if rel in (['lib'], ['main']): return ()
    if rel[-1] == 'mod': rel = rel[:-1]
    return tuple(rel)

def strip_comments(t):
    t = re.sub(r'/\*.*?\*/', '', t, flags=re.S)
    return '\n'.join(re.sub(r'//.*', '', l) for l in t.split('\n'))

def expand(tree):
    """expand a use tree 'a::{b, c::{d}}' into ['a::b', 'a::c::d']"""
    tree = tree.strip()
    m = re.match(r'^(.*?)\{(.*)\}$', tree, re.S)
    if not m: return [tree]
    pre, inner = m.group(1), m.group(2)
    parts, depth, cur = [], 0, ''
    for ch in inner:
        if ch == '{': depth += 1
        if ch == '}': depth -= 1
        if ch == ',' and depth == 0: parts.append(cur); cur = ''
        else: cur += ch
    parts.append(cur)
    out = []
    for p in parts:
        if p.strip(): out += [pre + q for q in expand(p)]
    return out

def inline_mod_ranges(text):
    """char ranges of inline `mod x { ... }` blocks -> names"""
    res = []
    for m in re.finditer(r'\bmod\s+(\w+)\s*\{', text):
        depth, i = 1, m.end()
        while i < len(text) and depth:
            if text[i] == '{': depth += 1
            elif text[i] == '}': depth -= 1
            i += 1
        res.append((m.start(), i, m.group(1)))
    return res

def main(crates):
    pairs = set()
    for crate in crates:
        src = os.path.join(crate, 'src')
        files = {}
        for root, _, fs in os.walk(src):
            for f in fs:
                if f.endswith('.rs'):
                    p = os.path.join(root, f)
                    files[modpath(src, p)] = p
        edges = {}
        for mp, f in files.items():
            text = strip_comments(open(f).read())
            ranges = inline_mod_ranges(text)
            paths = []
            for m in re.finditer(r'\buse\s+([^;]+);', text):
                for p in expand(m.group(1)):
                    paths.append((m.start(), p))
            for m in re.finditer(r'(?<![\w$])((?:\$crate|crate|super|self)(?:::\w+)+)', text):
                paths.append((m.start(), m.group(1)))
            for pos, p in paths:
                p = re.sub(r'\s+as\s+\w+$', '', p.strip()).replace(' ', '').replace('\n', '')
                segs = p.split('::')
                # module this code sits in (inline mods included)
                here = list(mp)
                for a, b, name in ranges:
                    if a <= pos < b: here.append(name)
                if segs[0] in ("crate", "$crate"): base, rest = [], segs[1:]
                elif segs[0] in ('super', 'self'):
                    base = here[:]
                    rest = segs
                    while rest and rest[0] in ('super', 'self'):
                        if rest[0] == 'super': base = base[:-1]
                        rest = rest[1:]
                else:
                    # relative path to a child module declared in this file
                    base, rest = here[:], segs
                full = base + rest
                # longest prefix naming a file
                target = None
                for k in range(len(full), -1, -1):
                    if tuple(full[:k]) in files:
                        target = tuple(full[:k]); break
                if target is None: continue
                if segs[0] not in ("crate", "$crate", "super", "self") and len(target) <= len(mp): continue
                tf = files[target]
                if tf != f:
                    edges.setdefault(f, set()).add(tf)
        for a, bs in edges.items():
            for b in bs:
                if a in edges.get(b, ()):
                    pairs.add(tuple(sorted((a, b))))
    for a, b in sorted(pairs):
        print(f'{a} <-> {b}')
    print(f'{len(pairs)} pair(s) of files import each other')
    return 1 if pairs else 0

sys.exit(main(sys.argv[1:]))
