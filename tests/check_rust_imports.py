#!/usr/bin/env python3
"""Every arrow points down, file by file (issue 41 §7): in each crate (crates/algo, crates/app
and the extension in src/), the graph "file A names an item of file B" (`use super::b::..`,
`super::b::f(..)`, `crate::x::b::..`, outside tests and comments) has no circle. Two files that
need each other's items share a leaf file instead (cluster/condensed.rs, geometry/error.rs).

A `mod.rs` that only declares and re-exports its children (`pub mod`, `pub use`) is a table of
contents, not a dependency: edges into a mod.rs count only for items defined in it.

Also: a binding file (src/bindings/<family>.rs) names no other family's binding file; helpers
that several bindings share live in the shared files listed in SHARED_BINDINGS.

usage: python3 tests/check_rust_imports.py
"""
import os
import re
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CRATES = {"crates/algo/src": "lib.rs", "crates/app/src": "lib.rs", "src": "lib.rs"}
# the files every binding may use: the descriptor vocabulary, the registry, the vectors (FFI)
SHARED_BINDINGS = {"types", "registry", "vector", "common", "mod"}


def strip(code):
    """Code without comments, string literals and #[cfg(test)] modules."""
    code = re.sub(r'r#*"(?:.|\n)*?"#*', '""', code)
    code = re.sub(r'"(?:\\.|[^"\\])*"', '""', code)
    code = re.sub(r"//[^\n]*", "", code)
    code = re.sub(r"/\*(?:.|\n)*?\*/", "", code)
    m = re.search(r"#\[cfg\(test\)\]\s*mod\s+\w+\s*\{", code)
    if m:
        code = code[: m.start()]
    return code


def module_of(root, path):
    """The module path of a file: ['cluster', 'mst'] for cluster/mst.rs, ['cluster'] for
    cluster/mod.rs, [] for lib.rs."""
    rel = os.path.relpath(path, root)[:-3].split(os.sep)
    if rel[-1] in ("mod", "lib"):
        rel = rel[:-1]
    return rel


def file_of(root, mod, files):
    """The deepest file that holds `mod` (a module path): [a, b, item] -> a/b.rs or a/b/mod.rs."""
    for k in range(len(mod), -1, -1):
        m = mod[:k]
        for cand in ([os.path.join(root, *m) + ".rs", os.path.join(root, *m, "mod.rs")] if m else [os.path.join(root, "lib.rs")]):
            if cand in files:
                return cand, mod[k:]
    return None, None


def toc_only(code):
    """A mod.rs with nothing but module declarations and re-exports."""
    body = re.sub(r"\s+", " ", code)
    body = re.sub(r"(pub(\([^)]*\))? )?(mod|use) [^;]*;", "", body)
    body = re.sub(r"#!?\[[^\]]*\]", "", body)
    return body.strip() == ""


def edges(root, files):
    out = {f: set() for f in files}
    for f in files:
        code = strip(open(f, encoding="utf-8").read())
        here = module_of(root, f)
        for m in re.finditer(r"\b((?:crate|super|self)(?:::super)*(?:::\w+)+)", code):
            segs = m.group(1).split("::")
            if segs[0] == "crate":
                mod = segs[1:]
            else:
                # `self` is this file's module; each `super` one up (from a/b.rs or a/b/mod.rs: a)
                base, k = list(here), 0
                if segs[0] == "self":
                    k = 1
                while k < len(segs) and segs[k] == "super":
                    base, k = base[:-1], k + 1
                mod = base + segs[k:]
            target, rest = file_of(root, mod, files)
            if target and target != f:
                out[f].add(target)
    return out


def cycles(graph, toc):
    """Strongly connected components of more than one file (Tarjan), ignoring edges into
    tables of contents."""
    g = {a: {b for b in bs if b not in toc} for a, bs in graph.items()}
    index, low, stack, on, comps, n = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = n[0]
        n[0] += 1
        stack.append(v)
        on.add(v)
        for w in g[v]:
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
                comps.append(sorted(comp))

    sys.setrecursionlimit(10000)
    for v in g:
        if v not in index:
            visit(v)
    return comps


def main():
    errors = []
    for rel_root in CRATES:
        root = os.path.join(ROOT, rel_root)
        files = set()
        for d, _, fs in os.walk(root):
            files.update(os.path.join(d, f) for f in fs if f.endswith(".rs"))
        graph = edges(root, files)
        toc = {f for f in files if os.path.basename(f) in ("mod.rs", "lib.rs") and toc_only(strip(open(f, encoding="utf-8").read()))}
        for comp in cycles(graph, toc):
            names = [os.path.relpath(c, ROOT) for c in comp]
            errors.append(f"a circle of imports: {' <-> '.join(names)}: move what they share into a leaf file")
        if rel_root == "src":
            b = os.path.join(root, "bindings")
            for f in sorted(graph):
                if os.path.dirname(f) != b:
                    continue
                for t in sorted(graph[f]):
                    name = os.path.splitext(os.path.relpath(t, b))[0].split(os.sep)[0]
                    if t.startswith(b + os.sep) and name not in SHARED_BINDINGS and t != f:
                        errors.append(f"{os.path.relpath(f, ROOT)} names {os.path.relpath(t, ROOT)}: a helper two bindings share belongs in a shared file ({', '.join(sorted(SHARED_BINDINGS - {'mod'}))})")
    for e in errors:
        print("FAIL: " + e, file=sys.stderr)
    if errors:
        sys.exit(1)
    print(f"check_rust_imports: no circle of imports between files in {', '.join(CRATES)}; no binding names another family's file")


if __name__ == "__main__":
    main()
