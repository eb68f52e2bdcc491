"""The source files the code checks read: core/, hal/, firmware/, tools/ and tests/, the
checks' own fixtures (any `testdata` folder) left out."""
import pathlib

FOLDERS = ('core', 'hal', 'firmware', 'tools', 'tests')


def sources(root: pathlib.Path, suffixes):
    """Every file under root's FOLDERS whose suffix is one of `suffixes`, sorted per folder."""
    for folder in FOLDERS:
        base = root / folder
        if not base.is_dir():
            continue
        for f in sorted(base.rglob('*')):
            if f.suffix in suffixes and f.is_file() and 'testdata' not in f.relative_to(root).parts:
                yield f
