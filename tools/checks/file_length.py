#!/usr/bin/env python3
"""No source file over --max lines (500), except the files of a list that may only shrink.

Every C/C++ source, fragment (.inc) and script (.py, .sh) under core/, hal/, firmware/, tools/
and tests/ (the checks' testdata fixtures aside) is counted. The list (--list, default
tools/checks/over_500_lines.txt) names the files that were over the limit when the check came
in, one per line as `LINES PATH`, with the count they had: such a file may not grow, and when it
shrinks its line must follow (lower the count, or delete the line once the file is within the
limit), so the list only ever gets shorter. Blank lines and `#` comments are ignored.

  tools/checks/file_length.py [--root DIR] [--max 500] [--list FILE]
Exit 1 on a file over the limit that is not listed, a listed file that grew, or a stale line.
"""
import argparse
import pathlib
import sys

import source_tree  # tools/checks/source_tree.py

SOURCES = ('.cpp', '.hpp', '.h', '.cc', '.c', '.inc', '.py', '.sh')


def sources(root):
    return source_tree.sources(root, SOURCES)


def line_count(path):
    text = path.read_text(errors='replace')
    return text.count('\n') + (0 if text.endswith('\n') or not text else 1)


def read_list(path):
    """{relative path: (allowed lines, line number in the list)}."""
    allowed = {}
    if not path.is_file():
        return allowed
    for n, raw in enumerate(path.read_text().split('\n'), 1):
        line = raw.split('#', 1)[0].strip()
        if not line:
            continue
        parts = line.split()
        if len(parts) != 2 or not parts[0].isdigit():
            raise SystemExit(f'error: {path}:{n}: expected "LINES PATH", got "{raw.strip()}"')
        allowed[parts[1]] = (int(parts[0]), n)
    return allowed


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    here = pathlib.Path(__file__).resolve()
    ap.add_argument('--root', default=here.parents[2], type=pathlib.Path)
    ap.add_argument('--max', type=int, default=500, help='longest file allowed (lines)')
    ap.add_argument('--list', type=pathlib.Path, default=None,
                    help='files over the limit that may only shrink (default: ROOT/tools/checks/over_500_lines.txt)')
    args = ap.parse_args()
    root = args.root.resolve()
    list_path = args.list or root / 'tools' / 'checks' / 'over_500_lines.txt'
    allowed = read_list(list_path)
    errors, count, listed_seen = [], 0, set()
    for f in sources(root):
        count += 1
        rel = f.relative_to(root).as_posix()
        lines = line_count(f)
        if rel in allowed:
            listed_seen.add(rel)
            was, n = allowed[rel]
            if lines > was:
                errors.append(f'{rel}: grew from {was} to {lines} lines; it is over {args.max} and listed in '
                              f'{list_path.name}:{n}, which may only shrink: split it (or move the new code to '
                              'a new file)')
            elif lines <= args.max:
                errors.append(f'{rel}: {lines} lines now, within {args.max}: delete its line '
                              f'({list_path.name}:{n})')
            elif lines < was:
                errors.append(f'{rel}: shrank from {was} to {lines} lines: lower its count in '
                              f'{list_path.name}:{n} to {lines}')
        elif lines > args.max:
            errors.append(f'{rel}: {lines} lines (at most {args.max}): split it into files by topic')
    for rel, (_, n) in sorted(allowed.items(), key=lambda kv: kv[1][1]):
        if rel not in listed_seen:
            errors.append(f'{list_path.name}:{n}: {rel} is not a source file here any more: delete its line')
    for e in errors:
        print('error: ' + e)
    print(f'{count} source files; {len(allowed)} listed over {args.max} lines, {len(errors)} problems')
    return 1 if errors else 0


if __name__ == '__main__':
    sys.exit(main())
