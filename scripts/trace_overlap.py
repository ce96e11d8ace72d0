#!/usr/bin/env python3
"""How far a sequence render overlaps its frames, read from a `--trace` file (issue #43).

For each pair of consecutive frames (n, n+1) it says whether frame n's `write` event (encoding
and writing the file, on a writer thread) overlaps in time
  - frame n+1's `node` events (the CPU recording frame n+1's passes), and
  - frame n+1's `gpu` events (its passes running on the GPU; only in a trace made with
    `--stats`, which times passes with timestamp queries).

    tyndall render graphs/stylize/tree_holes_animated.ron -o out/seq/f_####.exr \
        --frames 1-12 --size 960x540 --stats --trace out/seq.json
    python3 scripts/trace_overlap.py out/seq.json
"""
import json
import sys
from collections import defaultdict


def spans(events, cat):
    """Per frame: the (start, end) of every complete event of category `cat`, microseconds."""
    out = defaultdict(list)
    for e in events:
        if e.get("ph") == "X" and e.get("cat") == cat and "frame" in e.get("args", {}):
            out[e["args"]["frame"]].append((e["ts"], e["ts"] + e["dur"]))
    return out


def overlaps(a, b):
    return any(s0 < e1 and s1 < e0 for (s0, e0) in a for (s1, e1) in b)


def main(path):
    with open(path) as f:
        trace = json.load(f)
    events = trace["traceEvents"] if isinstance(trace, dict) else trace
    writes, nodes, gpu = spans(events, "write"), spans(events, "node"), spans(events, "gpu")
    frames = sorted(writes)
    pairs = [(n, m) for n, m in zip(frames, frames[1:])]
    with_nodes = sum(overlaps(writes[n], nodes.get(m, [])) for n, m in pairs)
    with_gpu = sum(overlaps(writes[n], gpu.get(m, [])) for n, m in pairs)
    for n, m in pairs:
        w = writes[n]
        print(
            f"frame {n} write {min(s for s, _ in w) / 1e3:9.1f}–{max(e for _, e in w) / 1e3:9.1f} ms"
            f" | frame {m} nodes {'overlap' if overlaps(w, nodes.get(m, [])) else '-'}"
            f" | frame {m} gpu {'overlap' if overlaps(w, gpu.get(m, [])) else ('-' if gpu.get(m) else 'none traced')}"
        )
    print(f"{len(pairs)} pairs: write(n) overlaps node events of n+1 in {with_nodes}, "
          f"GPU passes of n+1 in {with_gpu}")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(sys.argv[1])
