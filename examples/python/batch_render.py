"""Batch-render a preset library: every graph under a folder, its outputs written under an
output folder mirroring the library, with a line per preset.

    python examples/python/batch_render.py graphs/stylize out/stylize [--size 480x270] [--frames 1-3]
"""

import argparse
import pathlib
import time

import tyndall


def render_library(folder, out, size=(480, 270), frames=None):
    folder, out = pathlib.Path(folder), pathlib.Path(out)
    done = []
    for path in sorted(folder.rglob("*.ron")):
        if "lib" in path.relative_to(folder).parts:
            continue  # library groups are not presets
        g = tyndall.Graph.load(path)
        target = out / path.relative_to(folder).with_suffix("")
        target.mkdir(parents=True, exist_ok=True)
        start = time.perf_counter()
        try:
            rendered = tyndall.render(g, frames=frames, output_dir=target, size=size)
        except (tyndall.GraphError, tyndall.EvalError) as e:
            print(f"{path}: FAILED at {e.node}: {e}")
            continue
        print(f"{path}: {len(rendered)} frame(s) in {time.perf_counter() - start:.1f} s → {target}")
        done.append(path)
    return done


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("folder")
    p.add_argument("out")
    p.add_argument("--size", default="480x270")
    p.add_argument("--frames")
    a = p.parse_args()
    w, h = (int(x) for x in a.size.split("x"))
    render_library(a.folder, a.out, (w, h), a.frames)


if __name__ == "__main__":
    main()
