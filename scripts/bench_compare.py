"""Compare two `tyndall bench --csv` runs of one suite: per method, the geometric mean (and range)
of the median-time ratio B / A over its settings, and the settings whose RMSE changed.

    python3 scripts/bench_compare.py A.csv B.csv

Standard library only. BENCHMARKS.md's before/after tables (issue #60) come from it.
"""
import csv
import math
import sys


def load(path):
    with open(path, newline="") as f:
        return {r["setting"]: r for r in csv.DictReader(f) if r["row"] == "setting"}


def main():
    if len(sys.argv) != 3:
        sys.exit("usage: bench_compare.py A.csv B.csv")
    a, b = load(sys.argv[1]), load(sys.argv[2])
    common = [k for k in a if k in b]
    for method in ("BruteForce", "MinMax", "Epipolar"):
        ratios = [float(b[k]["median_ms"]) / float(a[k]["median_ms"])
                  for k in common if f"method={method}" in k]
        if ratios:
            mean = math.exp(sum(map(math.log, ratios)) / len(ratios))
            print(f"{method}: {len(ratios)} settings, time B/A {mean:.2f} "
                  f"(range {min(ratios):.2f}-{max(ratios):.2f})")
    for k in common:
        ra, rb = float(a[k]["rmse"]), float(b[k]["rmse"])
        if f"{ra:.6f}" != f"{rb:.6f}":
            print(f"RMSE changed: {k}: {ra:.6f} -> {rb:.6f}")


main()
