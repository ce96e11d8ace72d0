"""Graph-evaluation tests for a preset library, as a studio would write them for its own looks
(run with pytest from the repository root; `pytest --update-golden` rewrites the golden file).
"""

import pathlib

import numpy as np
import pytest

import tyndall
from tyndall.testing import assert_matches_golden

ROOT = pathlib.Path(__file__).resolve().parents[2]
SIZE = (96, 54)


@pytest.fixture(scope="module")
def ev():
    return tyndall.Evaluator()


@pytest.fixture(autouse=True)
def _in_root(monkeypatch):
    monkeypatch.chdir(ROOT)  # presets find their library groups from graphs/


def test_the_window_look_matches_its_golden_image(ev):
    g = tyndall.Graph.load("graphs/physical/window.ron")
    out = ev.eval(g, ["tonemap.out"], size=SIZE)
    # 40 dB: GPUs differ in the last bits of their floating point (lavapipe vs llvmpipe agree
    # to 113 dB on this preset), a changed look differs by far more.
    assert_matches_golden(out["tonemap.out"], ROOT / "examples/python/golden/window.exr", psnr=40)


def test_hole_filling_only_ever_closes_holes(ev):
    g = tyndall.Graph.load("graphs/stylize/tree_hole_filling.ron")
    g.set("shadow", "resolution", 256)
    out = ev.eval(g, ["shadow.map", "holes/close.map"], size=SIZE)
    shadow, closed = out["shadow.map"], out["holes/close.map"]
    assert np.all(closed <= shadow + 1e-6), "the closure never moves an occluder away"
    assert np.sum(closed < shadow - 1e-4) > 0, "and it fills some holes"


@pytest.mark.parametrize(
    "preset", sorted(p.stem for p in (ROOT / "graphs/physical").glob("*.ron"))
)
def test_physical_presets_stay_finite_and_in_display_range(ev, preset):
    g = tyndall.Graph.load(f"graphs/physical/{preset}.ron")
    for name, img in ev.eval(g, size=SIZE).items():
        assert np.isfinite(img).all(), name
        assert img.min() >= 0.0 and img.max() <= 1.0, name
