#!/usr/bin/env python3
"""List Rust functions that take two adjacent parameters of one integer type.

Usage: tools/adjacent-int-params.py [--fail] PATH...
       tools/adjacent-int-params.py --self-test

House rule: no function takes two adjacent parameters of the same integer
type (`u8` … `u128`, `usize`, `i8` … `i128`, `isize`); a named struct, a
newtype or an enum says which is which. Signatures may span lines and carry
generics, `where` clauses and `self` receivers; closures (`|a: u8, b: u8|`)
and `fn(u8, u8)` pointer types do not count. Skips `#[cfg(test)]` items and
files under `tests/`, `benches/`, `examples/`. With --fail, exits 1 if any
function breaks the rule (used by CI for the product code: core,
host-bridge, firmware, capi); no `.rs` file under the paths is an error
too. --self-test checks the parser on a sample with known offenders and
exits 1 unless it finds exactly those.
"""
import os
import re
import sys

INTS = {'u8', 'u16', 'u32', 'u64', 'u128', 'usize',
        'i8', 'i16', 'i32', 'i64', 'i128', 'isize'}
OPEN, CLOSE = '([{<', ')]}>'
FN = re.compile(r'\bfn\s+(\w+)\s*')
CFG_TEST = re.compile(r'#\[cfg\(test\)\]')


def blank(src):
    """`src` with comments, string and char literals replaced by spaces
    (newlines kept, so offsets and line numbers stay)."""
    out, i, n = [], 0, len(src)
    keep = lambda s: re.sub(r'[^\n]', ' ', s)
    while i < n:
        c = src[i]
        if src.startswith('//', i):
            j = src.find('\n', i)
            j = n if j < 0 else j
        elif src.startswith('/*', i):
            j, depth = i + 2, 1
            while j < n and depth:
                if src.startswith('/*', j):
                    depth, j = depth + 1, j + 2
                elif src.startswith('*/', j):
                    depth, j = depth - 1, j + 2
                else:
                    j += 1
        elif re.match(r'b?r#*"', src[i:i + 8]):
            m = re.match(r'b?r(#*)"', src[i:])
            end = src.find('"' + m.group(1), i + m.end())
            j = n if end < 0 else end + 1 + len(m.group(1))
        elif c == '"' or src.startswith('b"', i):
            j = i + (2 if c == 'b' else 1)
            while j < n and src[j] != '"':
                j += 2 if src[j] == '\\' else 1
            j += 1
        elif c == "'":
            m = re.match(r"'(\\(x..|u\{[^}]*\}|.)|[^\\'])'", src[i:])
            if not m:  # a lifetime
                out.append(c)
                i += 1
                continue
            j = i + m.end()
        else:
            out.append(c)
            i += 1
            continue
        out.append(keep(src[i:j]))
        i = j
    return ''.join(out)


def closing(s, i):
    """The index of the bracket that closes the one at `i` (`->` is no
    closing `>`), or None."""
    depth = 0
    for j in range(i, len(s)):
        c = s[j]
        if c in OPEN:
            depth += 1
        elif c in CLOSE and not (c == '>' and s[j - 1] in '-='):
            depth -= 1
            if depth == 0:
                return j
    return None


def split_top(s):
    """`s` split at the commas outside brackets."""
    parts, depth, cur = [], 0, []
    for j, c in enumerate(s):
        if c in OPEN:
            depth += 1
        elif c in CLOSE and not (c == '>' and j and s[j - 1] in '-='):
            depth -= 1
        if c == ',' and depth == 0:
            parts.append(''.join(cur))
            cur = []
        else:
            cur.append(c)
    if ''.join(cur).strip():
        parts.append(''.join(cur))
    return parts


def test_spans(s):
    """`(start, end)` offsets of the items under `#[cfg(test)]`."""
    spans = []
    for m in CFG_TEST.finditer(s):
        j = m.end()
        while j < len(s) and s[j] not in '{;':
            j += 1
        if j < len(s) and s[j] == '{':
            end = closing(s, j)
            spans.append((m.start(), len(s) if end is None else end))
        else:
            spans.append((m.start(), j))
    return spans


def offenders(src):
    """`(line, name, type)` of each function of `src` that breaks the rule."""
    s = blank(src)
    skip = test_spans(s)
    for m in FN.finditer(s):
        if any(a <= m.start() <= b for a, b in skip):
            continue
        i = m.end()
        if i < len(s) and s[i] == '<':
            end = closing(s, i)
            if end is None:
                continue
            i = end + 1
            while i < len(s) and s[i].isspace():
                i += 1
        if i >= len(s) or s[i] != '(':
            continue
        end = closing(s, i)
        if end is None:
            continue
        types = []
        for p in split_top(s[i + 1:end]):
            pattern, colon, ty = p.partition(':')
            types.append(' '.join(ty.split()) if colon else None)
        for a, b in zip(types, types[1:]):
            if a in INTS and a == b:
                yield s.count('\n', 0, m.start()) + 1, m.group(1), a
                break


SAMPLE = r'''
fn bad_simple(a: u8, b: u8) {}
pub(crate) const fn bad_multi_line<F: FnMut(&[u8]) -> Result<(), E>, E>(
    &mut self,
    first: usize, // "a comment, with: u8"
    last: usize,
    f: F,
) where F: Copy {}
fn bad_mut(mut a: i64, mut b: i64) -> i64 { a + b }
fn good_struct(r: Range, n: u8) {}
fn good_mixed(a: u8, b: u16, c: u8) {}
fn good_closure(f: impl Fn(u8, u8) -> u8, g: fn(u32, u32)) {
    let h = |a: u8, b: u8| a + b;
    let s = "fn bad_in_string(a: u8, b: u8)";
}
fn good_self(&mut self, a: u32) {}
/* fn bad_in_comment(a: u8, b: u8) {} */
#[cfg(test)]
mod tests {
    fn ignored(a: u8, b: u8) {}
}
'''


def self_test():
    found = [(line, name) for line, name, _ in offenders(SAMPLE)]
    want = [(2, 'bad_simple'), (3, 'bad_multi_line'), (9, 'bad_mut')]
    if found != want:
        print(f'self-test: found {found}, want {want}', file=sys.stderr)
        return 1
    print('self-test: 3 of 3 known offenders, no other', file=sys.stderr)
    return 0


def main(argv):
    if argv == ['--self-test']:
        return self_test()
    fail, paths = False, []
    for a in argv:
        if a == '--fail':
            fail = True
        else:
            paths.append(a)
    hits, read = [], 0
    for root in paths:
        for dirpath, dirs, files in os.walk(root):
            dirs[:] = sorted(d for d in dirs if d not in ('target', 'tests', 'benches', 'examples'))
            for f in sorted(files):
                if f.endswith('.rs'):
                    p = os.path.join(dirpath, f)
                    src = open(p, encoding='utf-8').read()
                    read += 1
                    for line, name, ty in offenders(src):
                        hits.append((p, line, name, ty))
    if not read:
        print('no .rs files under ' + ' '.join(paths), file=sys.stderr)
        return 1
    for p, line, name, ty in hits:
        print(f'{p}:{line} {name} ({ty}, {ty})')
    print(f'{len(hits)} functions with adjacent parameters of one integer type', file=sys.stderr)
    return 1 if fail and hits else 0


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))
