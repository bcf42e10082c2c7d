#!/usr/bin/env python3
"""List Rust functions longer than a limit (default 80 lines).

Usage: tools/long-fns.py [--max N] [--fail] PATH...

Counts the lines from a `fn` item's first line to its closing brace, skipping
`#[cfg(test)]` modules and files under `tests/`, `benches/`, `examples/`.
With --fail, exits 1 if any function is over the limit (used by CI for the
product code: core, host-bridge, firmware).
"""
import os
import re
import sys

FN = re.compile(r'^\s*(pub(\([^)]*\))?\s+)?(const\s+)?(unsafe\s+)?(extern\s+"[^"]*"\s+)?fn\s+(\w+)')


def strip(line):
    """The line without string/char literals and // comments (for brace counting)."""
    line = re.sub(r'"(\\.|[^"\\])*"', '""', line)
    line = re.sub(r"'(\\.|[^'\\])'", "''", line)
    return line.split('//', 1)[0]


def item_end(lines, start):
    """The last line of the item starting at `start`, and whether it has a
    body (a `{` before any `;`)."""
    j, depth, opened = start, 0, False
    while j < len(lines):
        s = strip(lines[j])
        depth += s.count('{') - s.count('}')
        opened = opened or '{' in s
        if opened and depth <= 0:
            break
        if not opened and s.rstrip().endswith(';'):
            break
        j += 1
    return j, opened


def functions(path):
    lines = open(path, encoding='utf-8').read().split('\n')
    i, n = 0, len(lines)
    while i < n:
        if re.match(r'\s*#\[cfg\(test\)\]', lines[i]):
            # Skip the item that follows (a test module or function).
            i = item_end(lines, i + 1)[0] + 1
            continue
        m = FN.match(lines[i])
        if m:
            j, opened = item_end(lines, i)
            if opened:
                yield m.group(6), i + 1, j - i + 1
            i += 1
            continue
        i += 1


def main(argv):
    limit, fail, paths = 80, False, []
    it = iter(argv)
    for a in it:
        if a == '--max':
            limit = int(next(it))
        elif a == '--fail':
            fail = True
        else:
            paths.append(a)
    long = []
    for root in paths:
        for dirpath, dirs, files in os.walk(root):
            dirs[:] = [d for d in dirs if d not in ('target', 'tests', 'benches', 'examples')]
            for f in sorted(files):
                if f.endswith('.rs'):
                    p = os.path.join(dirpath, f)
                    for name, line, length in functions(p):
                        if length > limit:
                            long.append((length, p, line, name))
    for length, p, line, name in sorted(long, reverse=True):
        print(f'{length:5} {p}:{line} {name}')
    print(f'{len(long)} functions over {limit} lines', file=sys.stderr)
    return 1 if fail and long else 0


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))
