"""Wedge a quality knob and print time against error — no plotting library needed.

    python examples/python/wedge.py [graph] [node.param] [values…]

Default: SingleScattering's `steps` (with method BruteForce, where steps is the knob) in
graphs/physical/window.ron against a 256-step reference
(same input, same run), error as RMSE and PSNR of the tone-mapped picture. Times are wall-clock
milliseconds of the nodes that ran (the evaluator's cache keeps the scene, shadow map and
G-buffer, so only the scattering and what is below it run per setting).
"""

import sys
import time

import tyndall
from tyndall.testing import psnr, rmse


def wedge(path="graphs/physical/window.ron", knob="scatter.steps", values=(8, 16, 32, 64, 128),
          reference=256, output="tonemap.out", size=(320, 180), fixed=None):
    node, param = knob.split(".")
    g = tyndall.Graph.load(path)
    if fixed is None:
        fixed = {"scatter.method": "BruteForce"} if knob == "scatter.steps" else {}
    for k, v in fixed.items():
        g.set(*k.split("."), v)
    ev = tyndall.Evaluator()
    g.set(node, param, reference)
    ref = ev.eval(g, [output], size=size)[output]
    rows = []
    for v in values:
        g.set(node, param, v)
        start = time.perf_counter()
        out = ev.eval(g, [output], size=size)
        wall = (time.perf_counter() - start) * 1e3
        ran_ms = sum(n.ms for n in out.stats.nodes if n.status == "ran")
        rows.append((v, ran_ms, wall, rmse(out[output], ref), psnr(out[output], ref)))
    return rows


def main(argv):
    path = argv[1] if len(argv) > 1 else "graphs/physical/window.ron"
    knob = argv[2] if len(argv) > 2 else "scatter.steps"
    values = [int(v) for v in argv[3:]] or [8, 16, 32, 64, 128]
    rows = wedge(path, knob, values)
    print(f"{knob:>16} {'nodes ms':>9} {'wall ms':>8} {'RMSE':>9} {'PSNR dB':>8}")
    for v, ms, wall, e, p in rows:
        bar = "#" * max(1, int(ms / max(r[1] for r in rows) * 30))
        print(f"{v:>16} {ms:9.1f} {wall:8.1f} {e:9.5f} {p:8.2f}  {bar}")


if __name__ == "__main__":
    main(sys.argv)
