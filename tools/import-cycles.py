#!/usr/bin/env python3
"""Find import circles between the modules of a Rust crate.

Usage: tools/import-cycles.py [--edges] SRC_DIR...

Each SRC_DIR is a crate's `src/`; its roots are `lib.rs`, `main.rs` and
`bin/*.rs` (each root a crate of its own). Prints every circle and exits 1
if there is one, 0 otherwise; --edges also prints the whole graph.

The graph (python3 only, no packages; a reader of the source, not a
compiler, so it is conservative where it must guess):

* Nodes are modules: `mod NAME;` (file `NAME.rs` or `NAME/mod.rs`) and
  inline `mod NAME { … }`. A node stands for the module's *own* items, the
  code of its own file; its child modules are nodes of their own.
* Test code is left out: modules and items under `#[cfg(test)]` (or
  `#[cfg(all(test, …))]`), which are free to reach anywhere.
* Module M depends on module T when M's own code names an item that T
  defines: through `use` (`crate::`, `super::`, `self::` and uniform paths
  relative to M), through a path in code (`crate::a::b`, `super::x`,
  `child::f()`, `Imported::CONST`), or through a glob import of T (the
  names M uses that T provides). A path is followed through re-exports
  (`pub use`) and private imports to the module where the item is defined,
  so a facade does not count as the owner of what it re-exports.
* A `pub use` that M's own code does not use is a re-export, not a
  dependency of M; `mod` declarations are not dependencies either.

The rule for a circle: modules are compared with their siblings. An edge
from a module under sibling A to a module under sibling B (A and B
children of one parent P) is an edge A -> B at P's level, so the use of a
cousin counts for the two siblings that hold them. A circle is a strongly
connected component of two or more siblings at some level. A child naming
its parent's own items (`super::X`, X defined in the parent's file)
depends on those items, not on its siblings, and a parent calling into
its children is the parent using its parts: neither is an edge between
siblings, so a parent and its children alone make no circle (the types a
`mod.rs` declares, a crate root's constants are the context its children
are written in). Where two siblings both need something, it moves into a
module below both (or into the lower of the two), and the circle goes.

Each circle is printed with one shortest cycle through it and, for every
edge of that cycle, the first place in the source that makes it. Not
seen: items that a macro brings into scope by name (`#[macro_export]`
macros, `foo!()` without a path) and trait methods called without naming
the trait's module.
"""
import os
import re
import sys

WORD = re.compile(r'\w+')


def clean(text):
    """`text` with comments and the contents of string and char literals
    replaced by spaces (newlines kept, so offsets and lines stay)."""
    out = list(text)
    i, n = 0, len(text)

    def blank(a, b):
        for k in range(a, b):
            if out[k] != '\n':
                out[k] = ' '

    while i < n:
        c = text[i]
        if text.startswith('//', i):
            j = text.find('\n', i)
            j = n if j < 0 else j
            blank(i, j)
            i = j
        elif text.startswith('/*', i):
            depth, j = 1, i + 2
            while j < n and depth:
                if text.startswith('/*', j):
                    depth, j = depth + 1, j + 2
                elif text.startswith('*/', j):
                    depth, j = depth - 1, j + 2
                else:
                    j += 1
            blank(i, j)
            i = j
        elif re.match(r'b?r#*"', text[i:i + 260]) and (i == 0 or not (text[i - 1].isalnum() or text[i - 1] == '_')):
            m = re.match(r'b?r(#*)"', text[i:])
            end = text.find('"' + m.group(1), i + m.end())
            end = n if end < 0 else end
            blank(i + m.end(), end)
            i = end + 1 + len(m.group(1))
        elif c == '"':
            j = i + 1
            while j < n and text[j] != '"':
                j += 2 if text[j] == '\\' else 1
            blank(i + 1, j)
            i = j + 1
        elif c == "'":
            if text.startswith('\\', i + 1):
                j = text.find("'", i + 3)
                blank(i + 1, j)
                i = j + 1
            elif i + 2 < n and text[i + 2] == "'":
                blank(i + 1, i + 2)
                i += 3
            else:
                i += 1  # a lifetime
        else:
            i += 1
    return ''.join(out)


def matching(text, i):
    """Index just past the brace that closes the `{` at `i`."""
    depth = 0
    for j in range(i, len(text)):
        if text[j] == '{':
            depth += 1
        elif text[j] == '}':
            depth -= 1
            if depth == 0:
                return j + 1
    return len(text)


def item_end(text, i):
    """End of the item starting at `i`: its `;` before any `{`, or the brace
    that closes its body."""
    semi, brace = text.find(';', i), text.find('{', i)
    if brace < 0 or 0 <= semi < brace:
        return len(text) if semi < 0 else semi + 1
    return matching(text, brace)


def blank_span(text, a, b):
    return text[:a] + re.sub(r'[^\n]', ' ', text[a:b]) + text[b:]


TEST_CFG = re.compile(r'#\s*\[\s*cfg\s*\(\s*(test\s*\)|all\s*\(\s*test\b)')


def drop_tests(text):
    """`text` with every item under `#[cfg(test)]` blanked."""
    while True:
        m = TEST_CFG.search(text)
        if not m:
            return text
        text = blank_span(text, m.start(), item_end(text, m.end()))


class Module:
    def __init__(self, path, parent, file, text):
        self.path = path            # tuple of names, () for the crate root
        self.parent = parent
        self.file = file
        self.full = text            # the file's cleaned text (for line numbers)
        self.children = {}
        self.own = ''               # own code, children's bodies blanked
        self.uses = []              # (segments, name, glob, public, pos)
        self.defs = set()
        self.pub_defs = set()       # defs and child modules with `pub…`
        self.code = ''              # own code without use statements

    def line(self, pos):
        return self.full.count('\n', 0, pos) + 1


MOD = re.compile(r'\b(?:pub\s*(?:\([^)]*\))?\s*)?mod\s+(\w+)\s*([;{])')


def load(file, path, parent, modules, text=None, dirpath=None):
    """Read the module at `file` (or the inline module `text`, whose child
    files are under `dirpath`) and its children into `modules`."""
    if text is None:
        text = drop_tests(clean(open(file, encoding='utf-8').read()))
        base = os.path.basename(file)
        d = os.path.dirname(file)
        owns_dir = base in ('lib.rs', 'main.rs', 'mod.rs') or path == ()
        dirpath = d if owns_dir else os.path.join(d, base[:-3])
        full = text
    else:
        full = parent.full
    m = Module(path, parent, file, full)
    modules[path] = m
    own = text
    pos = 0
    while True:
        found = MOD.search(own, pos)
        if not found:
            break
        name = found.group(1)
        if found.group(0).startswith('pub'):
            m.pub_defs.add(name)
        if found.group(2) == ';':
            for cand in (os.path.join(dirpath, name + '.rs'), os.path.join(dirpath, name, 'mod.rs')):
                if os.path.isfile(cand):
                    m.children[name] = load(cand, path + (name,), m, modules)
                    break
            own = blank_span(own, found.start(), found.end())
            pos = found.end()
        else:
            start = found.end() - 1
            end = matching(own, start)
            # Same offsets as the file: the text before the body blanked.
            body = re.sub(r'[^\n]', ' ', own[:start + 1]) + own[start + 1:end - 1]
            m.children[name] = load(file, path + (name,), m, modules, text=body,
                                    dirpath=os.path.join(dirpath, name))
            own = blank_span(own, found.start(), end)
            pos = end
    m.own = own
    parse_uses(m)
    return m


USE = re.compile(r'(\bpub\s*(?:\([^)]*\))?\s*)?\buse\s+')


def parse_tree(tokens, i, prefix, out):
    path = list(prefix)
    while i < len(tokens):
        t = tokens[i]
        if t == '::':
            i += 1
        elif t == '{':
            i += 1
            while i < len(tokens) and tokens[i] != '}':
                if tokens[i] == ',':
                    i += 1
                    continue
                i = parse_tree(tokens, i, path, out)
            return i + 1
        elif t == '*':
            out.append((path, None, True))
            return i + 1
        elif t in (',', '}'):
            return i
        else:
            path.append(t)
            i += 1
            if i < len(tokens) and tokens[i] == 'as':
                out.append((path, tokens[i + 1], False))
                return i + 2
            if i >= len(tokens) or tokens[i] != '::':
                out.append((path, None, False))
                return i
    return i


def parse_uses(m):
    code = m.own
    for u in list(USE.finditer(m.own)):
        end = m.own.find(';', u.end())
        trees = []
        parse_tree(re.findall(r'::|[{},*]|\w+', m.own[u.end():end]), 0, [], trees)
        for segs, alias, glob in trees:
            if segs and segs[-1] == 'self':
                segs = segs[:-1]
            name = None if glob else (alias or (segs[-1] if segs else None))
            m.uses.append((segs, name, glob, bool(u.group(1)), u.start()))
        code = blank_span(code, u.start(), end + 1)
    m.code = code
    for d in re.finditer(r'(\bpub\s*(?:\([^)]*\))?\s*)?\b(?:fn|struct|enum|trait|type|const|static|union)\s+(\w+)', code):
        m.defs.add(d.group(2))
        if d.group(1):
            m.pub_defs.add(d.group(2))
    m.defs |= set(re.findall(r'macro_rules!\s*(\w+)', code))


class Crate:
    def __init__(self, root_file):
        self.modules = {}
        self.root = load(root_file, (), None, self.modules)

    def namespace(self, m, seen_from=None):
        """Names visible in `m` besides the preludes (children, own items,
        imports), or, `seen_from` another module not inside `m`, the ones a
        glob import of `m` brings it (the `pub` ones)."""
        if seen_from is not None and seen_from.path[:len(m.path)] != m.path:
            names = set(m.pub_defs)
            names |= {name for _, name, glob, public, _ in m.uses if name and public}
            return names
        names = set(m.children) | m.defs
        names |= {name for _, name, glob, _, _ in m.uses if name}
        return names

    def resolve(self, m, segs, seen=None, depth=0):
        """(module, item or None) that the path `segs` names from module `m`,
        following imports; None if it leaves the crate."""
        seen = set() if seen is None else seen
        key = (m.path, tuple(segs))
        if key in seen:
            return None
        seen.add(key)
        cur, i = m, 0
        if segs and segs[0] == 'crate':
            cur, i = self.root, 1
        elif segs and segs[0] in ('super', 'self'):
            while i < len(segs) and segs[i] in ('super', 'self'):
                if segs[i] == 'super':
                    cur = cur.parent or cur
                i += 1
        elif not segs or segs[0] not in self.namespace(m) and not self.by_glob(m, segs[0], depth):
            return None
        while i < len(segs):
            s = segs[i]
            if s in cur.children:
                cur = cur.children[s]
                i += 1
                continue
            if s in cur.defs:
                return (cur, s)
            target = self.through_import(cur, s, seen)
            if target is None:
                return (cur, s)
            mod, item = target
            if item is not None:
                return (mod, item)
            cur = mod
            i += 1
        return (cur, None)

    def through_import(self, m, name, seen):
        for segs, alias, glob, _, _ in m.uses:
            if not glob and alias == name:
                return self.resolve(m, segs, seen)
        via = self.by_glob(m, name)
        if via is not None:
            return self.resolve(m, via + [name], seen)
        return None

    def by_glob(self, m, name, depth=0):
        """The path of the glob import through which `name` reaches `m`."""
        if depth > 8:
            return None
        for segs, _, glob, _, _ in m.uses:
            if glob and segs:
                g = self.resolve(m, segs, depth=depth + 1)
                if g and g[1] is None and (name in self.namespace(g[0], m)
                                           or self.by_glob(g[0], name, depth + 1)):
                    return segs
        return None

    def edges(self):
        """{(from, to): (module, pos, text)} over the crate's own code."""
        found = {}

        def add(m, target, pos, text):
            if target is None or target[0] is m:
                return
            found.setdefault((m.path, target[0].path), (m, pos, text))

        for m in self.modules.values():
            used = set(WORD.findall(m.code))
            for segs, name, glob, public, pos in m.uses:
                if glob:
                    g = self.resolve(m, segs) if segs else None
                    if g and g[1] is None:
                        for n in sorted(used & self.namespace(g[0], m)):
                            target = self.resolve(g[0], [n])
                            # A module's name as a word is no use of it:
                            # its paths (`name::x`) are followed below.
                            if target and target[1] is not None:
                                add(m, target, pos, '::'.join(segs) + '::* (' + n + ')')
                    continue
                if public and name not in used:
                    continue  # a re-export
                add(m, self.resolve(m, segs), pos, '::'.join(segs))
            for p in re.finditer(r'(?<![\w:])((?:\w+\s*::\s*)+\w+)', m.code):
                segs = [s for s in re.split(r'\s*::\s*', p.group(1))]
                if segs[0] in ('Self', 'std', 'core', 'alloc'):
                    continue
                add(m, self.resolve(m, segs), p.start(), p.group(1))
        return found


def tarjan(nodes, succ):
    index, low, on, stack, out = {}, {}, set(), [], []
    counter = [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in succ.get(v, ()):
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
            out.append(comp)

    sys.setrecursionlimit(10000)
    for v in nodes:
        if v not in index:
            visit(v)
    return out


def shortest_cycle(start, succ, members):
    """A shortest cycle from `start` back to it inside `members`."""
    prev, frontier = {start: None}, [start]
    while frontier:
        nxt = []
        for v in frontier:
            for w in sorted(succ.get(v, ())):
                if w not in members:
                    continue
                if w == start:
                    path = [v]
                    while prev[path[-1]] is not None:
                        path.append(prev[path[-1]])
                    return list(reversed(path)) + [start]
                if w not in prev:
                    prev[w] = v
                    nxt.append(w)
        frontier = nxt
    return [start]


def show(path):
    return '::'.join(path) or 'crate'


def sibling_edges(edges):
    """The module edges lifted to the level where they cross between two
    siblings: {parent: {(child, child): (from, to)}} (the first module edge
    that makes each). An edge between a module and one of its ancestors
    crosses no siblings."""
    levels = {}
    for (a, b) in sorted(edges):
        k = 0
        while k < min(len(a), len(b)) and a[k] == b[k]:
            k += 1
        if k < len(a) and k < len(b):
            levels.setdefault(a[:k], {}).setdefault((a[:k + 1], b[:k + 1]), (a, b))
    return levels


def check(root_file, print_edges):
    crate = Crate(root_file)
    edges = crate.edges()
    if print_edges:
        for (a, b), (m, pos, text) in sorted(edges.items()):
            print(f'  {show(a)} -> {show(b)}   ({os.path.relpath(m.file)}:{m.line(pos)}: {text})')
    circles = 0
    for parent, level in sorted(sibling_edges(edges).items()):
        succ = {}
        for (a, b) in level:
            succ.setdefault(a, set()).add(b)
        for comp in tarjan(sorted(succ), succ):
            if len(comp) < 2:
                continue
            circles += 1
            comp = sorted(comp)
            cycle = shortest_cycle(comp[0], succ, set(comp))
            print(f'circle in {root_file}: {{{", ".join(show(c) for c in comp)}}}')
            for a, b in zip(cycle, cycle[1:]):
                x, y = level[(a, b)]
                m, pos, text = edges[(x, y)]
                print(f'  {show(a)} -> {show(b)}   {os.path.relpath(m.file)}:{m.line(pos)}: '
                      f'{show(x)} names {text}')
    return circles, len(crate.modules)


def main(argv):
    print_edges = '--edges' in argv
    dirs = [a for a in argv if a != '--edges']
    if not dirs:
        print(__doc__.split('\n\n')[1], file=sys.stderr)
        return 2
    total = 0
    for d in dirs:
        roots = [os.path.join(d, f) for f in ('lib.rs', 'main.rs') if os.path.isfile(os.path.join(d, f))]
        bins = os.path.join(d, 'bin')
        if os.path.isdir(bins):
            roots += sorted(os.path.join(bins, f) for f in os.listdir(bins) if f.endswith('.rs'))
        for r in roots:
            n, modules = check(r, print_edges)
            print(f'{r}: {modules} modules, {n} circle(s)')
            total += n
    return 1 if total else 0


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))
