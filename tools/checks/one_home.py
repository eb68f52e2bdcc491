#!/usr/bin/env python3
"""Each shared fact is defined in one place: a grep over core/, hal/, firmware/, tools/ and tests/.

Every row of FACTS is a fact, the regular expression that finds a definition of it, and the one
file allowed to hold that definition (None: a literal no file may write; the named constant is
its home). The check fails (exit 1) when the definition is found
anywhere else (a copy that could drift), or not in its home (the table is stale). Add a row
when a fact gets its one home.

  tools/checks/one_home.py [--root DIR]
"""
import argparse
import pathlib
import re
import sys

FACTS = [
    # (what, regular expression of a definition, its one home)
    ('the sweep window of load-cell readings', r'\bconstexpr\s+\w+\s+kForceWindow\s*=',
     'core/include/thrustcal/sweep_rules.hpp'),
    ('the central-mean width of the force reading', r'\bconstexpr\s+\w+\s+kForceCentral\s*=',
     'core/include/thrustcal/sweep_rules.hpp'),
    ('settle auto: the probe period', r'\bconstexpr\s+\w+\s+kSettleProbeMs\s*=',
     'core/include/thrustcal/sweep_rules.hpp'),
    ('settle auto: the counts two medians may differ by', r'\bconstexpr\s+\w+\s+kSettledCounts\s*=',
     'core/include/thrustcal/sweep_rules.hpp'),
    ('settle auto: the agreeing pairs', r'\bconstexpr\s+\w+\s+kSettledAgreements\s*=',
     'core/include/thrustcal/sweep_rules.hpp'),
    ('settle auto: the default cap', r'\bconstexpr\s+\w+\s+kDefaultSettleCapMs\s*=',
     'core/include/thrustcal/sweep_rules.hpp'),
    ('the settle-auto rule', r'\bagreements\s*=\s*[^;]*\?\s*[^;]*agreements\s*\+\s*1',
     'core/include/thrustcal/sweep_rules.hpp'),
    ('the cycle probe: GPIOR0 as a marker register (host side)', r'avr_register_io_write\([^)]*[Gg]pior0',
     'tools/sim/src/cycle_probe.cpp'),
    ('the stack figure status prints, parsed', r'stack: \(\\d\+\) of \(\\d\+\) bytes never used',
     'tools/sim/src/stack_scenario.cpp'),
    ('the Intel HEX reader', r'^std::vector<uint8_t>\s+parseIntelHex\([^;{]*\{',
     'tools/hex/src/intel_hex.cpp'),
    ('a slot\'s flown model (the v1/v2 union)', r'\bclass\s+SlotModel\b',
     'core/include/thrustcal/slot_model.hpp'),
    # The board (hal/board.hpp): the firmware, the simulator, the plant and the tools read it.
    ('the CPU clock', r'\bconstexpr\s+[\w:]+\s+k\w*CpuHz\s*=\s*\d', 'hal/include/hal/board.hpp'),
    ('the EEPROM size', r'\bconstexpr\s+[\w:]+\s+k\w*Eeprom\w*\s*=\s*\d', 'hal/include/hal/board.hpp'),
    ('the flash size', r'\bconstexpr\s+[\w:]+\s+k\w*Flash\w*Bytes\s*=\s*\d', 'hal/include/hal/board.hpp'),
    ('a UART baud rate', r'\bconstexpr\s+[\w:]+\s+k\w*Baud\s*=\s*\d', 'hal/include/hal/board.hpp'),
    ('the ESC pin table', r'\bEscPin\s+kEscPins\[\]\s*=', 'hal/include/hal/board.hpp'),
    ('the Mega2560 header pin map', r'\bMegaPin\s+kMegaPins\[', 'hal/include/hal/mega_pins.hpp'),
    ('an ESC pin as a (port, bit) literal', r"\{\s*'[A-L]'\s*,\s*[0-7]\s*\}", None),
    ('the timer driver\'s pulse clamp', r'\bconstexpr\s+[\w:]+\s+kPulseClamp(Min|Max)Us\s*=',
     'hal/include/hal/board.hpp'),
    # Protocol facts (core).
    ('the ESC\'s throttle range', r'\bconstexpr\s+[\w:]+\s+kThrottle(Min|Max)Us\s*=',
     'core/include/thrustcal/record_limits.hpp'),
    ('a bare throttle-range default', r'\buint16_t\s+pwm_(min|max)_us\s*=\s*(1000|2000)\s*;', None),
    ('gather_store\'s setting ranges', r'\bconstexpr\s+[\w:]+\s+kSweep(Pwm|Step|Settle)\w*\s*=',
     'core/include/thrustcal/sweep_limits.hpp'),
    ('the flash-text macros', r'#\s*define\s+TC_FLASH', 'core/include/thrustcal/flash_text.hpp'),
]
SOURCES = ('.cpp', '.hpp', '.h', '.c', '.inc')
FOLDERS = ('core', 'hal', 'firmware', 'tools', 'tests')


def sources(root):
    for folder in FOLDERS:
        base = root / folder
        if not base.is_dir():
            continue
        for f in sorted(base.rglob('*')):
            if f.suffix in SOURCES and f.is_file() and 'testdata' not in f.relative_to(root).parts:
                yield f


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--root', default=pathlib.Path(__file__).resolve().parents[2], type=pathlib.Path)
    args = ap.parse_args()
    root = args.root.resolve()
    found = {i: [] for i in range(len(FACTS))}
    patterns = [re.compile(rx, re.M) for _, rx, _ in FACTS]
    for f in sources(root):
        text = f.read_text(errors='replace')
        for i, rx in enumerate(patterns):
            for m in rx.finditer(text):
                found[i].append((f.relative_to(root).as_posix(), text.count('\n', 0, m.start()) + 1))
    failed = False
    for i, (what, _, home) in enumerate(FACTS):
        places = found[i]
        if home is None:  # a literal that must not be written anywhere
            for p, n in places:
                failed = True
                print(f'error: {p}:{n}: writes {what}; read it from its named constant instead')
            continue
        elsewhere = [(p, n) for p, n in places if p != home]
        for p, n in elsewhere:
            failed = True
            print(f'error: {p}:{n}: defines {what} again; its one home is {home}: use it from there')
        if not any(p == home for p, _ in places):
            failed = True
            print(f'error: {home} no longer defines {what}: move the row in tools/checks/one_home.py '
                  'to where it lives now')
    if not failed:
        print(f'one home: {len(FACTS)} facts, each defined once')
    return 1 if failed else 0


if __name__ == '__main__':
    sys.exit(main())
