#!/usr/bin/env python3
"""The docs stand alone: they cite nothing outside the repository, and the code names the
glossary gives exist in the sources.

  tools/checks/docs_standalone.py outside [--root DIR]
      README.md, docs/*.md, every README.md under tools/, and the sources and build files of
      core/, hal/, firmware/, tools/ and tests/ name no file outside the repository: no design
      brief or convention notes of the people who wrote it (DESIGN.md, CONVENTIONS.md), no
      ../shared/ or /work/ path. A fact they need is written in docs/ instead.
  tools/checks/docs_standalone.py glossary [--root DIR]
      every code name in docs/glossary.md exists: a qualified name (`fw::Motor`) is declared in a
      file that opens its namespace, a function (`recip26Of()`) is declared, a file name
      (`model_v2_fixed_point.hpp`) is a file, a snake_case name (`pwm_us`) is an identifier of
      the sources. The thesis's own names (the first column of the "Thesis vocabulary" table) and
      the bare suffixes (`_us`) are not code names.
Exit 1 naming file:line and what to do.
"""
import argparse
import pathlib
import re
import sys

FOLDERS = ('core', 'hal', 'firmware', 'tools', 'tests')
CODE = ('.cpp', '.hpp', '.h', '.c', '.cc', '.inc')
BUILD = ('.cmake', '.txt', '.sh', '.py', '.json')
OUTSIDE = re.compile(r'\b(DESIGN|CONVENTIONS)\.md\b|\.\./shared/|/work/|\bshared/(data|notes|seed)\b')


def files(root, suffixes, name=None):
    for folder in FOLDERS:
        base = root / folder
        if not base.is_dir():
            continue
        for f in sorted(base.rglob('*')):
            rel = f.relative_to(root)
            if not f.is_file() or 'testdata' in rel.parts:
                continue
            if (name and f.name == name) or f.suffix in suffixes:
                yield f


def outside(root):
    here = pathlib.Path(__file__).resolve()
    docs = [root / 'README.md'] + sorted((root / 'docs').glob('*.md')) + list(files(root, (), 'README.md'))
    scanned = [f for f in docs if f.is_file()] + [
        f for f in files(root, CODE + BUILD) if f.resolve() != here]
    problems = []
    for f in scanned:
        for n, line in enumerate(f.read_text(errors='replace').split('\n'), 1):
            m = OUTSIDE.search(line)
            if m:
                problems.append(f'{f.relative_to(root)}:{n}: cites "{m.group(0)}", which is not in this '
                                'repository: write the fact it needs in docs/ in your own words and cite that')
    return problems, f'{len(scanned)} files cite nothing outside the repository'


def glossary_names(path):
    """[(line, name)] of the code names in the glossary's tables."""
    names, section = [], ''
    for n, line in enumerate(path.read_text().split('\n'), 1):
        if line.startswith('## '):
            section = line[3:].strip().lower()
        if not line.startswith('|') or re.match(r'^\|[-| ]+\|$', line):
            continue
        cells = line.strip().strip('|').split('|')
        if section.startswith('thesis'):
            cells = cells[1:]  # the thesis's own names are not this code's
        for cell in cells:
            for token in re.findall(r'`([^`]+)`', cell):
                names.append((n, token))
    return names


def kind_of(token):
    if ' ' in token or '*' in token or token.startswith('_'):
        return None  # a command line, a pattern, a bare suffix
    if re.fullmatch(r'\w+(::\w+)+', token):
        return 'qualified'
    if re.fullmatch(r'[\w:]+\(\)', token):
        return 'function'
    if re.fullmatch(r'[\w./]+\.(hpp|cpp|h|c|inc)', token):
        return 'file'
    if re.fullmatch(r'(\w+\.)*[a-z][a-z0-9]*(_[a-z0-9]+)+', token):
        return 'identifier'
    return None


def glossary(root):
    sources = {f: f.read_text(errors='replace') for f in files(root, CODE)}
    everything = '\n'.join(sources.values())
    path = root / 'docs' / 'glossary.md'
    problems, checked = [], 0
    for n, token in glossary_names(path):
        kind = kind_of(token)
        if not kind:
            continue
        checked += 1
        where = f'docs/glossary.md:{n}: `{token}`'
        if kind == 'qualified':
            *space, name = token.split('::')
            opens = re.compile(r'\bnamespace\s+' + r'\s*(::|\{\s*namespace)\s*'.join(space) + r'\b')
            declares = re.compile(r'\b(struct|class|union|enum(\s+class)?|using)\s+' + name + r'\b|'
                                  r'^[^;(){}=]*[\w>&*]\s+[&*]?' + name + r'\s*\(', re.M)
            if not any(opens.search(t) and declares.search(t) for t in sources.values()):
                homes = sorted({f.relative_to(root).as_posix() for f, t in sources.items()
                                if re.search(r'\b(struct|class)\s+' + name + r'\b', t)})
                hint = f' ({name} is declared in {", ".join(homes)})' if homes else ''
                problems.append(f'{where} is not declared in namespace {"::".join(space)}{hint}: name it as the code does')
        elif kind == 'function':
            name = token[:-2].split('::')[-1]
            if not re.search(r'\b' + name + r'\s*\(', everything):
                problems.append(f'{where}: no function {name} in the sources: name it as the code does')
        elif kind == 'file':
            if not any(f.name == pathlib.Path(token).name for f in sources):
                problems.append(f'{where}: no such file in the sources')
        else:
            name = token.split('.')[-1]
            if not re.search(r'\b' + name + r'\b', everything):
                problems.append(f'{where}: no identifier {name} in the sources: name it as the code does')
    return problems, f'docs/glossary.md: {checked} code names, each in the sources'


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('what', choices=('outside', 'glossary'))
    ap.add_argument('--root', default=pathlib.Path(__file__).resolve().parents[2], type=pathlib.Path)
    args = ap.parse_args()
    root = args.root.resolve()
    problems, ok = (outside if args.what == 'outside' else glossary)(root)
    for p in problems:
        print('error: ' + p)
    print(ok if not problems else f'{len(problems)} problems')
    return 1 if problems else 0


if __name__ == '__main__':
    sys.exit(main())
