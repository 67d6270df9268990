"""Mutations of text, bytes and parsed YAML trees (pure Python, deterministic given the rng)."""

from __future__ import annotations

import random
import struct
from typing import Any

#: Tokens that break parsers: float limits, non-numbers, huge integers, odd syntax.
INTERESTING_TOKENS = (
    "0",
    "-0",
    "1",
    "-1",
    "1e300",
    "-1e300",
    "1e-320",
    "1.7976931348623157e308",
    "1e309",
    "nan",
    "NaN",
    "inf",
    "-inf",
    ".inf",
    ".nan",
    "1" + "0" * 400,
    "9" * 30,
    "-9" * 20,
    "0x10",
    "1_000",
    "",
    "[",
    "]",
    "{",
    "}",
    "%",
    ":",
    "- ",
    "~",
    "null",
    "true",
    "[1, 2, 3]",
    "{a: 1}",
    "{1: 2}",
    "!!binary x",
    "2024-13-45",
    "&a [*a]",
    "é",
    "\x00",
    "\t",
    "[]",
    "pi/0",
    "-pi/2",
    "165*deg",
    "1e6",
    "-1e6",
    "1000000.1",
    *("/dev/zero", "/dev/stdin", "/", "n" * 300, "d/" * 2100),  # files no loader may read
)

#: Values for YAML-tree mutations: numbers at every limit, wrong types, odd keys, deep nesting.
INTERESTING_VALUES: tuple[Any, ...] = (
    0,
    -1,
    1,
    2,
    255,
    256,
    65535,
    2**31,
    2**63,
    -(2**63),
    10**400,
    -(10**400),
    0.0,
    -0.0,
    1e-320,
    1e300,
    -1e300,
    1e6,
    float("inf"),
    float("-inf"),
    float("nan"),
    True,
    False,
    None,
    "",
    "x",
    "pi/0",
    "1e400",
    "-pi/2",
    [],
    [0],
    [1, 2],
    [0.0, 0.0, 0.0],
    [[1, 2], [3, 4]],
    {},
    {"a": 1},
    {1: 2},
    {None: 1},
    {(1, 2): 3},
    [[[[[[[[[[0]]]]]]]]]],
    *("/dev/zero", "/dev/stdin", ".", "n" * 300, "d/" * 2100, "nul\0name"),  # paths no loader may read
)

_INTERESTING_INTS = (0, 1, -1, 0x7F, 0x80, 0xFF, 0x7FFF, 0xFFFF, 0x7FFFFFFF, 0x80000000, 0xFFFFFFFF)


def mutate_bytes(rng: random.Random, data: bytes, rounds: int | None = None) -> bytes:
    """A few random edits: bit flips, interesting integers, inserted/deleted/duplicated runs, a cut."""
    buf = bytearray(data)
    for _ in range(rounds if rounds is not None else rng.choice((1, 1, 2, 3, 5, 10))):
        op = rng.randrange(8)
        n = len(buf)
        if n == 0:
            buf += bytes(rng.randrange(256) for _ in range(rng.randrange(1, 16)))
            continue
        pos = rng.randrange(n)
        if op == 0:
            buf[pos] ^= 1 << rng.randrange(8)
        elif op == 1:
            buf[pos] = rng.choice((0, 1, 0x7F, 0x80, 0xFF, rng.randrange(256)))
        elif op == 2:
            width = rng.choice((2, 4, 8))
            value = rng.choice(_INTERESTING_INTS) if width < 8 else rng.choice((0, 2**63 - 1, 2**64 - 1, 2**32))
            packed = struct.pack("<Q", value & 0xFFFFFFFFFFFFFFFF)[:width]
            buf[pos : pos + width] = packed
        elif op == 3:
            del buf[pos : pos + rng.choice((1, 4, 16, 256, 4096))]
        elif op == 4:
            buf[pos:pos] = bytes(rng.randrange(256) for _ in range(rng.choice((1, 4, 16))))
        elif op == 5:
            start = rng.randrange(n)
            length = min(rng.choice((4, 64, 1024)), n - start)
            buf[pos:pos] = buf[start : start + length]
        elif op == 6:
            del buf[pos:]  # truncated
        else:
            buf[pos : pos + 8] = struct.pack("<d", rng.choice((float("nan"), float("inf"), 1e300, -1e300, 0.0)))
    return bytes(buf)


def mutate_text(rng: random.Random, text: str, donors: list[str] | None = None, rounds: int | None = None) -> str:
    """Line and token edits: drop/duplicate/swap lines, replace tokens, splice, insert junk, cut."""
    lines = text.splitlines()
    for _ in range(rounds if rounds is not None else rng.choice((1, 1, 2, 3, 6))):
        op = rng.randrange(9)
        if not lines:
            lines.append(rng.choice(INTERESTING_TOKENS))
            continue
        i = rng.randrange(len(lines))
        if op == 0:
            del lines[i]
        elif op == 1:
            lines.insert(i, lines[rng.randrange(len(lines))])
        elif op == 2:
            j = rng.randrange(len(lines))
            lines[i], lines[j] = lines[j], lines[i]
        elif op in (3, 4, 5):
            tokens = lines[i].split(" ")
            k = rng.randrange(len(tokens))
            token = rng.choice(INTERESTING_TOKENS)
            # Keep YAML's "key:" and list dashes most of the time so the value is what changes.
            if tokens[k].endswith(":") and rng.random() < 0.7 and k + 1 < len(tokens):
                k += 1
            tokens[k] = token
            lines[i] = " ".join(tokens)
        elif op == 6 and donors:
            donor = rng.choice(donors).splitlines()
            if donor:
                lines.insert(i, donor[rng.randrange(len(donor))])
        elif op == 7:
            chars = list(lines[i])
            if chars:
                code = rng.choice((0, 9, 32, 35, 37, 45, 58, 91, 93, 123, 0xE9, 0x1F600))
                chars[rng.randrange(len(chars))] = chr(code)
            lines[i] = "".join(chars)
        else:
            cut = rng.randrange(len(lines[i]) + 1)
            lines[i] = lines[i][:cut]
            if rng.random() < 0.3:
                del lines[i + 1 :]
    return "\n".join(lines) + ("\n" if rng.random() < 0.9 else "")


def _paths(tree: Any, prefix: tuple = ()) -> list[tuple]:
    """Paths (key/index tuples) of every node of a YAML tree, the root included."""
    out = [prefix]
    if isinstance(tree, dict):
        for k, v in tree.items():
            out += _paths(v, (*prefix, k))
    elif isinstance(tree, list):
        for i, v in enumerate(tree):
            out += _paths(v, (*prefix, i))
    return out


def _get(tree: Any, path: tuple) -> Any:
    for key in path:
        tree = tree[key]
    return tree


def mutate_tree(rng: random.Random, tree: Any, rounds: int | None = None) -> Any:
    """Edit a deep copy of a YAML tree: replace, delete, duplicate, add keys (odd ones too)."""
    import copy

    tree = copy.deepcopy(tree)
    for _ in range(rounds if rounds is not None else rng.choice((1, 1, 2, 3))):
        paths = _paths(tree)
        path = rng.choice(paths)
        if not path:
            if rng.random() < 0.05:
                tree = copy.deepcopy(rng.choice(INTERESTING_VALUES))
            continue
        parent = _get(tree, path[:-1])
        key = path[-1]
        op = rng.randrange(7)
        value = copy.deepcopy(rng.choice(INTERESTING_VALUES))
        if op <= 2:
            parent[key] = value
        elif op == 3:
            del parent[key]
        elif op == 4:
            if isinstance(parent, list):
                parent.insert(key, copy.deepcopy(parent[key]))
            else:
                parent[rng.choice(("extra", 7, None, True, 1.5, key))] = value
        elif op == 5:
            node = parent[key]
            if isinstance(node, (int, float)) and not isinstance(node, bool):
                try:
                    whole = int(node) if node == node and abs(node) < 1e18 else node
                    parent[key] = rng.choice((-node, node * 1e300, node + 1e-9, node * 1000, whole))
                except OverflowError:  # an integer beyond float range: make it bigger still
                    parent[key] = node * 10 ** rng.randrange(400)
            else:
                parent[key] = value
        else:
            node = parent[key]
            if isinstance(node, list) and node:
                del node[rng.randrange(len(node)) :]
            else:
                parent[key] = [node, node] if rng.random() < 0.5 else {"k": node}
    return tree


def dump_yaml(tree: Any) -> str:
    """YAML text of a tree (any key type; huge integers written out in full)."""
    import yaml

    try:
        return yaml.safe_dump(tree, allow_unicode=True, sort_keys=False)
    except (yaml.YAMLError, ValueError, TypeError, RecursionError):  # e.g. a tuple key
        return yaml.dump(tree, allow_unicode=True, sort_keys=False)


# ---------------------------------------------------------------------------------------------
# Hostile YAML: alias bombs ("billion laughs") at any key of a document
# ---------------------------------------------------------------------------------------------

_BOMB_MARK = "__alias_bomb_here__"


def alias_bomb(levels: int = 10, width: int = 10) -> str:
    """A flow sequence of ``levels`` nested anchors, each ``width`` aliases of the one before: a
    few hundred bytes of text standing for ``width ** levels`` values (10 x 10: 10 billion)."""
    items = [f"&lol0 [{', '.join(['lol'] * width)}]"]
    items += [f"&lol{k} [{', '.join([f'*lol{k - 1}'] * width)}]" for k in range(1, levels)]
    return "[" + ", ".join(items) + "]"


def yaml_paths(tree: Any) -> list[tuple]:
    """Paths (key/index tuples) of every node of a YAML tree, the root (``()``) included."""
    return _paths(tree)


def bombed_yaml(tree: Any, path: tuple, levels: int = 10, width: int = 10) -> str:
    """YAML text of ``tree`` with the value at ``path`` (``()``: the whole document; a key not in
    the mapping there: a new key) replaced by :func:`alias_bomb`."""
    import copy

    if not path:
        return alias_bomb(levels, width) + "\n"
    tree = copy.deepcopy(tree)
    _get(tree, path[:-1])[path[-1]] = _BOMB_MARK
    text = dump_yaml(tree)
    return text.replace(_BOMB_MARK, alias_bomb(levels, width), 1)
