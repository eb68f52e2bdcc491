#!/usr/bin/env python3
"""No host function a reader cannot hold: every C++ function body under the given folders is at
most --max lines (signature to closing brace), unless a `// long: REASON` comment sits on its
signature or in the comment block right above it.

A brace counter, not a compiler: comments, string and character literals (raw strings too) and
preprocessor lines are blanked first; a `{` at namespace or class level opens a function when
the text before it (since the last `;`, `{` or `}`) has a parameter list and is not a
namespace, class, enum or an initializer (`= {`). Lambdas and local classes count towards the
function they are in. A fragment pasted into a function by `#include "X.inc"` (the AVR assembly
frame of model v2) counts with its lines, as if written there.

  tools/checks/function_length.py [--max 80] [--all] PATH...
Exit 1 when a function is too long and carries no reason; --all lists every function over the
limit, reasons included. Folders named testdata (the checks' own fixtures) are skipped when a
folder is given.
"""
import argparse
import pathlib
import re
import sys

SOURCES = ('.cpp', '.hpp', '.h', '.cc', '.c', '.inc')
SCOPE = re.compile(r'\b(namespace|class|struct|union)\b')
LONG_MARK = re.compile(r'//\s*long:\s*\S')
INCLUDE_INC = re.compile(r'^\s*#\s*include\s+"([^"]+\.inc)"')


def blank(text):
    """The text with comments, literals and preprocessor lines replaced by spaces (newlines
    kept, so offsets and line numbers stay)."""
    out = list(text)
    i, n = 0, len(text)

    def wipe(a, b):
        for k in range(a, b):
            if out[k] != '\n':
                out[k] = ' '

    line_start = True
    while i < n:
        c = text[i]
        if line_start and c == '#':  # preprocessor line, with its continuations
            j = i
            while j < n and (text[j] != '\n' or text[j - 1] == '\\'):
                j += 1
            wipe(i, j)
            i = j
            continue
        if c == '\n':
            line_start = True
            i += 1
            continue
        if not c.isspace():
            line_start = False
        if text.startswith('//', i):
            j = text.find('\n', i)
            j = n if j < 0 else j
            wipe(i, j)
            i = j
        elif text.startswith('/*', i):
            j = text.find('*/', i + 2)
            j = n if j < 0 else j + 2
            wipe(i, j)
            i = j
        elif c == 'R' and text.startswith('"', i + 1) and not (i and (text[i - 1].isalnum() or text[i - 1] == '_')):
            m = re.match(r'R"([^(\s]*)\(', text[i:])
            if not m:
                i += 1
                continue
            end = text.find(')' + m.group(1) + '"', i)
            j = n if end < 0 else end + len(m.group(1)) + 2
            wipe(i + 1, j)
            i = j
        elif c in '"\'':
            if c == "'" and i and text[i - 1].isalnum():  # digit separator: 1'000
                i += 1
                continue
            j = i + 1
            while j < n and text[j] != c and text[j] != '\n':
                j += 2 if text[j] == '\\' else 1
            wipe(i + 1, j)
            i = j + 1
        else:
            i += 1
    return ''.join(out)


def header_kind(header):
    """'scope', 'function' or 'other' for the text in front of a `{` outside any function."""
    h = ' '.join(header.split())
    if not h:
        return 'other'
    if re.search(r'\benum\b', h):
        return 'other'
    if h.startswith('extern'):
        return 'scope'
    paren = h.find('(')
    scope = SCOPE.search(h)
    if scope and (paren < 0 or scope.start() < paren):
        return 'scope'
    if paren < 0 or ')' not in h:
        return 'other'
    depth = 0
    for ch in h:  # an '=' outside the parentheses: an initializer, a lambda's variable
        depth += ch == '('
        depth -= ch == ')'
        if ch == '=' and depth == 0:
            return 'other'
    return 'function'


def function_name(header):
    h = ' '.join(header.split())
    m = re.search(r'((?:[\w~]+::)*(?:operator\s*[^\s(]+|[\w~]+))\s*\(', h)
    return m.group(1) if m else h[:40]


def pasted_lines(path, lines, first, last, seen=()):
    """[(fragment, lines)] of the `#include "X.inc"` lines in lines[first-1..last-1], each
    fragment with what it includes in turn."""
    out = []
    for line in lines[first - 1:last]:
        m = INCLUDE_INC.match(line)
        if not m:
            continue
        inc = (path.parent / m.group(1)).resolve()
        if inc in seen or not inc.is_file():
            continue
        inc_lines = inc.read_text(errors='replace').split('\n')
        count = len(inc_lines) - (inc_lines[-1] == '')
        out.append((inc.name, count))
        out += pasted_lines(inc, inc_lines, 1, len(inc_lines), seen + (inc,))
    return out


def functions(path):
    """[(name, first_line, last_line, reason_or_None, pasted)] for every function body in the
    file; pasted: the fragments it includes, [(file name, lines)]."""
    raw = path.read_text(errors='replace')
    text = blank(raw)
    lines = raw.split('\n')
    found = []
    stack = []  # 'scope' | 'function' | 'other' | 'block'
    header_start = 0
    opened = []  # (first_line, name) of the open functions
    i, n = 0, len(text)
    while i < n:
        c = text[i]
        if c == '{':
            inside = any(k == 'function' for k in stack) or (stack and stack[-1] == 'other')
            header = text[header_start:i]
            if not inside and re.search(r'\)\s*(const\s*)?(noexcept\s*)?:[^:]', header) \
                    and re.search(r'\w\s*$', header):
                # a member initializer `x_{...}` of a constructor: part of the signature
                depth, j = 0, i
                while j < n:
                    depth += text[j] == '{'
                    depth -= text[j] == '}'
                    if depth == 0:
                        break
                    j += 1
                i = j + 1
                continue
            kind = 'block' if inside else header_kind(header)
            stack.append(kind)
            if kind == 'function':
                offset = header_start + len(header) - len(header.lstrip())
                first = text.count('\n', 0, offset) + 1
                opened.append((first, function_name(header)))
            header_start = i + 1
        elif c == '}':
            kind = stack.pop() if stack else 'other'
            if kind == 'function':
                first, name = opened.pop()
                last = text.count('\n', 0, i) + 1
                found.append((name, first, last, reason(lines, first),
                              pasted_lines(path, lines, first, last)))
            header_start = i + 1
        elif c == ';':
            header_start = i + 1
        i += 1
    return found


def reason(lines, first):
    """The `// long: ...` text on the signature line or the comment block above it."""
    k = first - 1
    if LONG_MARK.search(lines[k]):
        return LONG_MARK.search(lines[k]).string[LONG_MARK.search(lines[k]).start():].strip()
    k -= 1
    while k >= 0 and lines[k].strip().startswith('//'):
        m = LONG_MARK.search(lines[k])
        if m:
            return lines[k][m.start():].strip()
        k -= 1
    return None


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('paths', nargs='+', type=pathlib.Path)
    ap.add_argument('--max', type=int, default=80, help='longest function allowed (lines)')
    ap.add_argument('--all', action='store_true', help='list marked functions over the limit too')
    args = ap.parse_args()
    files = []
    for p in args.paths:
        if p.is_dir():
            files += sorted(f for f in p.rglob('*') if f.suffix in SOURCES and f.is_file()
                            and 'testdata' not in f.relative_to(p).parts)
        elif p.is_file():
            files.append(p)
        else:
            print(f'error: {p}: no such file or folder')
            return 2
    if not files:
        print('error: no C++ sources under ' + ' '.join(map(str, args.paths)))
        return 2
    too_long, marked, count = [], [], 0
    for f in files:
        for name, first, last, why, pasted in functions(f):
            count += 1
            # an include line is replaced by the fragment's lines
            length = last - first + 1 + sum(n - 1 for _, n in pasted)
            if length <= args.max:
                continue
            where = ''
            if pasted:
                where = ' (' + ', '.join(f'{n} from {inc}' for inc, n in pasted) + ')'
            (marked if why else too_long).append((f, first, name, f'{length} lines{where}', why))
    for f, first, name, length, why in too_long:
        print(f'{f}:{first}: {name} is {length} (at most {args.max}): split it into named '
              'steps, or say why it stays long with a `// long: REASON` comment above it')
    if args.all:
        for f, first, name, length, why in marked:
            print(f'{f}:{first}: {name} is {length}, {why}')
    print(f'{count} functions in {len(files)} files; {len(too_long)} over {args.max} lines without '
          f'a reason, {len(marked)} with one')
    return 1 if too_long else 0


if __name__ == '__main__':
    sys.exit(main())
