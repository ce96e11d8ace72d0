#!/usr/bin/env python3
"""A graph of N Math nodes in a chain after a Constant (each output's type follows the one
before it): the document-size benchmark of README *Graph files*.

    python3 scripts/make_chain.py 10000 > /tmp/chain.ron && tyndall validate /tmp/chain.ron
"""
import sys

n = int(sys.argv[1]) if len(sys.argv) > 1 else 10000
out = ['(version: 3, nodes: {', '    "c": (kind: "Constant", params: {"value": 0.5}),']
out += [f'    "m{i}": (kind: "Math", params: {{"op": "add", "b": 0.001}}),' for i in range(n)]
out.append('}, edges: [')
prev = "c.value"
for i in range(n):
    out.append(f'    ("{prev}", "m{i}.a"),')
    prev = f"m{i}.out"
out.append('])')
print("\n".join(out))
