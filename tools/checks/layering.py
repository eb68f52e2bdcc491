#!/usr/bin/env python3
"""The tools' include graph points downhill (docs/architecture.md, "Layers").

Reads every `#include "..."` under tools/ and resolves it the way the build does: a header in
tools/<folder>/include/ is an edge to that folder; one in core/include or hal/include is
downhill by definition; one that exists only under firmware/ is a firmware's private header,
which no tool may include. Fails (exit 1) on:
  - a cycle between tools folders (a folder that includes, directly or through others, from
    a folder that includes it back), naming one include line per edge of the cycle;
  - a tools file that includes a header found only under firmware/.
Prints the folder graph with --graph.

  tools/checks/layering.py [--root DIR] [--graph]
"""
import argparse
import pathlib
import re
import sys

INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"', re.M)
SOURCES = ('.cpp', '.hpp', '.h', '.c', '.inc')


def sources(folder):
    """The C++ files of a tools folder; test fixtures (testdata/) are not part of it."""
    return sorted(f for f in folder.rglob('*')
                  if f.suffix in SOURCES and f.is_file() and 'testdata' not in f.relative_to(folder).parts)


def tools_folders(root):
    return sorted(p.name for p in (root / 'tools').iterdir() if p.is_dir() and sources(p))


def resolve(root, folders, src, header):
    """Where `header` included from `src` lives: ('tools', folder), ('lower', path),
    ('firmware', path) or (None, None) for a system or generated header."""
    here = src.parent / header
    if here.is_file():  # next to the includer: its own folder
        return ('tools', src.relative_to(root / 'tools').parts[0])
    for folder in folders:
        if (root / 'tools' / folder / 'include' / header).is_file():
            return ('tools', folder)
    for lower in ('core/include', 'hal/include'):
        if (root / lower / header).is_file():
            return ('lower', lower + '/' + header)
    hits = [p for p in (root / 'firmware').rglob(pathlib.Path(header).name)
            if p.as_posix().endswith(header)]
    if hits:
        return ('firmware', hits[0].relative_to(root).as_posix())
    return (None, None)


def edges_of(root, folders):
    """{(from, to): first 'file:line: #include' that makes the edge}, firmware includes."""
    edges, private = {}, []
    for folder in folders:
        for src in sources(root / 'tools' / folder):
            text = src.read_text(errors='replace')
            for m in INCLUDE.finditer(text):
                line = text.count('\n', 0, m.start()) + 1
                where = f'{src.relative_to(root)}:{line}: #include "{m.group(1)}"'
                kind, target = resolve(root, folders, src, m.group(1))
                if kind == 'tools' and target != folder:
                    edges.setdefault((folder, target), where)
                elif kind == 'firmware':
                    private.append(f'{where} is {target}, a firmware header')
    return edges, private


def find_cycle(folders, edges):
    """One cycle as a list of folders [a, b, ..., a], or None (depth-first search)."""
    graph = {f: sorted(t for (s, t) in edges if s == f) for f in folders}
    state, stack = {}, []

    def visit(f):
        state[f] = 'open'
        stack.append(f)
        for t in graph[f]:
            if state.get(t) == 'open':
                return stack[stack.index(t):] + [t]
            if t not in state:
                found = visit(t)
                if found:
                    return found
        stack.pop()
        state[f] = 'done'
        return None

    for f in folders:
        if f not in state:
            found = visit(f)
            if found:
                return found
    return None


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--root', default=pathlib.Path(__file__).resolve().parents[2], type=pathlib.Path)
    ap.add_argument('--graph', action='store_true', help='print every folder edge')
    args = ap.parse_args()
    root = args.root.resolve()
    folders = tools_folders(root)
    edges, private = edges_of(root, folders)
    if args.graph:
        for (s, t), where in sorted(edges.items()):
            print(f'{s} -> {t}    ({where})')
    failed = False
    cycle = find_cycle(folders, edges)
    if cycle:
        failed = True
        print('error: tools folders include each other in a cycle: ' + ' -> '.join(cycle))
        for s, t in zip(cycle, cycle[1:]):
            print(f'  {s} -> {t}: {edges[(s, t)]}')
        print('  move what both need into a lower folder (docs/architecture.md, "Layers")')
    for p in private:
        failed = True
        print(f'error: {p}: tools include core/, hal/ or a tools library, never a firmware '
              'image\'s own headers')
    if not failed:
        print(f'layering ok: {len(folders)} tools folders, {len(edges)} folder edges, no cycle, '
              'no firmware header')
    return 1 if failed else 0


if __name__ == '__main__':
    sys.exit(main())
