"""Colour management from Python (issue #45, item 7): ``ocio=`` on Evaluator, node and render,
``convert_colourspace``, and ``tyndall.testing`` comparisons in a chosen colour space."""

import numpy as np
import pytest

import tyndall
from tyndall.testing import assert_images_close

# The repository's small config: `linear` (scene_linear) and `graded`, a 5³ .cube 3D LUT.
CUSTOM = "tests/fixtures/ocio/config.ocio"
BUILTIN = "ocio://cg-config-v4.0.0_aces-v2.0_ocio-v2.5"

# Published Linear Rec.709 → ACEScg (AP1) matrix (ACES TB-2014-004 / OpenColorIO's built-in
# configs), rows = output channels.
REC709_TO_AP1 = np.array(
    [
        [0.6130973, 0.3395229, 0.0473793],
        [0.0701942, 0.9163556, 0.0134526],
        [0.0206156, 0.1095698, 0.8698151],
    ]
)


def test_convert_colourspace_matches_the_published_matrix_and_the_srgb_curve():
    rgb = np.eye(3, dtype=np.float32).reshape(1, 3, 3)
    ap1 = tyndall.convert_colourspace(rgb, "ACEScg", ocio=BUILTIN)
    assert ap1.shape == (1, 3, 3) and ap1.dtype == np.float32
    # 2e-3: the published matrix's rounding against the config's chromatic adaptation.
    np.testing.assert_allclose(ap1[0].T, REC709_TO_AP1, atol=2e-3)
    grey = np.array([[[0.18, 0.18, 0.18, 0.5]]], dtype=np.float32)
    enc = tyndall.convert_colourspace(grey, "sRGB Encoded Rec.709 (sRGB)", ocio=BUILTIN)
    # 0.18 → 1.055 · 0.18^(1/2.4) − 0.055 = 0.4614; alpha untouched.
    np.testing.assert_allclose(enc[0, 0, :3], 0.4614, atol=1e-4)
    assert enc[0, 0, 3] == 0.5
    back = tyndall.convert_colourspace(ap1, "", source="ACEScg", ocio=BUILTIN)
    np.testing.assert_allclose(back, rgb, atol=1e-5)
    with pytest.raises(ValueError, match="H×W×3 or H×W×4"):
        tyndall.convert_colourspace(np.zeros((2, 2), np.float32), "ACEScg")
    with pytest.raises(ValueError, match="Rec.2020-ish"):
        tyndall.convert_colourspace(rgb, "Rec.2020-ish", ocio=BUILTIN)


def test_evaluator_and_render_take_a_config(root, tmp_path):
    custom = str(root / CUSTOM)
    ev = tyndall.Evaluator(ocio=custom)
    assert ev.ocio == custom
    with pytest.raises(ValueError, match="nowhere.ocio"):
        tyndall.Evaluator(ocio=str(tmp_path / "nowhere.ocio"))
    g = tyndall.Graph.from_str('(version: 3, nodes: {"c": (kind: "Constant", params: {})})')
    with pytest.raises(ValueError, match="nowhere.ocio"):
        tyndall.render(g, output_dir=str(tmp_path), ocio=str(tmp_path / "nowhere.ocio"))


def test_the_config_reaches_the_evaluation(root, tmp_path):
    custom = str(root / CUSTOM)
    # A working space only the custom config has: it evaluates there and fails under the
    # built-in config, naming the space.
    text = """(version: 3, colour: (working_space: "graded"), nodes: {
        "c": (kind: "Constant", params: {"colour": (0.5, 0.25, 0.125, 1.0)}),
        "cs": (kind: "ColourSpace", params: {"to": "linear"}),
    }, edges: [("c.colour", "cs.image")])"""
    g = tyndall.Graph.from_str(text)
    out = tyndall.Evaluator(ocio=custom).eval(g, ["cs.image"], size=(4, 4))["cs.image"]
    img = np.full((4, 4, 4), [0.5, 0.25, 0.125, 1.0], np.float32)
    cpu = tyndall.convert_colourspace(img, "linear", source="graded", ocio=custom)
    # 1e-5: the GPU's LUT interpolation against the CPU's (measured 6e-8 in tests/nodes).
    np.testing.assert_allclose(out, cpu, atol=1e-5)
    assert np.abs(out - img).max() > 0.01  # the LUT did something
    with pytest.raises(tyndall.EvalError, match="graded"):
        tyndall.Evaluator(ocio=BUILTIN).eval(g, ["cs.image"], size=(4, 4))
    # One node with a config, as tyndall node --ocio.
    one = tyndall.node(
        "ColourSpace", {"from": "linear", "to": "graded"}, {"image": img}, ocio=custom
    )["image"]
    ref = tyndall.convert_colourspace(img, "graded", source="linear", ocio=custom)
    np.testing.assert_allclose(one, ref, atol=1e-5)
    # And render writes through it.
    g = tyndall.Graph.from_str(
        text.replace("}, edges", '"o": (kind: "ImageOutput", params: {"path": "c.exr"}),\n}, edges')
        .replace('("c.colour", "cs.image")', '("c.colour", "cs.image"), ("cs.image", "o.image")')
    )
    tyndall.render(g, output_dir=str(tmp_path), size=(4, 4), ocio=custom)
    np.testing.assert_allclose(tyndall.read_image(tmp_path / "c.exr"), out, atol=1e-6)


def test_images_compare_in_a_chosen_colourspace():
    # Two pictures 0.002 apart in the shadows: close in linear values, 10× further apart once
    # sRGB-encoded (the curve's slope is 12.92 there), which is what an eye sees.
    a = np.full((8, 8, 3), 0.001, np.float32)
    b = a + 0.002
    assert_images_close(a, b, rmse=0.005)
    with pytest.raises(AssertionError, match="RMSE"):
        assert_images_close(
            a, b, rmse=0.005, colourspace="sRGB Encoded Rec.709 (sRGB)", ocio=BUILTIN
        )
    # Highlights: the other way round.
    c = np.full((8, 8, 3), 0.9, np.float32)
    assert_images_close(c, c + 0.006, rmse=0.005, colourspace="sRGB Encoded Rec.709 (sRGB)")
    with pytest.raises(AssertionError, match="RMSE"):
        assert_images_close(c, c + 0.006, rmse=0.005)
