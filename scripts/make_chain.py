#!/usr/bin/env python3
"""A graph of N Math nodes in a chain after a Constant (each output's type follows the one
before it): the document-size benchmark of README *Graph files*. With --grid, the nodes have
canvas positions in rows of 40 (what an editor opens; without it they take the editor's
default diagonal).

    python3 scripts/make_chain.py 10000 > /tmp/chain.ron && tyndall validate /tmp/chain.ron
"""
import sys

args = [a for a in sys.argv[1:] if not a.startswith("--")]
grid = "--grid" in sys.argv
n = int(args[0]) if args else 10000


def pos(i):
    return f", pos: ({(i % 40) * 220.0}, {(i // 40) * 140.0})" if grid else ""


out = ['(version: 3, nodes: {', f'    "c": (kind: "Constant", params: {{"value": 0.5}}{pos(0)}),']
out += [
    f'    "m{i}": (kind: "Math", params: {{"op": "add", "b": 0.001}}{pos(i + 1)}),'
    for i in range(n)
]
out.append('}, edges: [')
prev = "c.value"
for i in range(n):
    out.append(f'    ("{prev}", "m{i}.a"),')
    prev = f"m{i}.out"
out.append('])')
print("\n".join(out))
