"""Assertions for graph-evaluation tests (pytest or plain ``assert``).

    from tyndall.testing import assert_images_close, assert_matches_golden

    def test_window_look(golden_update):
        out = tyndall.Evaluator().eval(tyndall.Graph.load("graphs/physical/window.ron"),
                                       ["tonemap.out"], size=(320, 180))
        assert_matches_golden(out["tonemap.out"], "golden/window.exr", psnr=40,
                              update=golden_update)

``pytest --update-golden`` (this package's pytest plugin) makes the ``golden_update`` fixture
true: golden files are then written instead of compared.

``colourspace=`` compares two scene-linear pictures where the eye would, e.g.
``colourspace="sRGB Encoded Rec.709 (sRGB)"`` (a colour space of the ``ocio`` config: its
name, an alias or a role; both arrays are converted from ``source``, the working space unless
given, on the CPU with OpenColorIO, before the comparison).
"""

from __future__ import annotations

import math
import os
import tempfile
from pathlib import Path
from typing import Optional, Union

import numpy as np

from ._native import convert_colourspace, read_image, write_image

PathLike = Union[str, "os.PathLike[str]"]

__all__ = ["psnr", "rmse", "assert_images_close", "assert_matches_golden"]


def rmse(a: np.ndarray, b: np.ndarray) -> float:
    """Root-mean-square difference over every sample (same shapes)."""
    a, b = _pair(a, b)
    return float(np.sqrt(np.mean((a - b) ** 2)))


def psnr(a: np.ndarray, b: np.ndarray, peak: float = 1.0) -> float:
    """Peak signal-to-noise ratio in dB, 20 log10(peak / RMSE); infinite for equal arrays."""
    e = rmse(a, b)
    return math.inf if e == 0.0 else 20.0 * math.log10(peak / e)


def _pair(a: np.ndarray, b: np.ndarray):
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    if a.shape != b.shape:
        raise AssertionError(f"shapes differ: {a.shape} vs {b.shape}")
    return a, b


def _diff_path(name: Optional[PathLike]) -> Path:
    if name is not None:
        return Path(name)
    folder = Path(os.environ.get("TYNDALL_DIFF_DIR", tempfile.gettempdir()))
    fd, path = tempfile.mkstemp(prefix="tyndall-diff-", suffix=".exr", dir=folder)
    os.close(fd)
    return Path(path)


def _in_colourspace(
    a: np.ndarray, colourspace: Optional[str], source: str, ocio: Optional[PathLike]
) -> np.ndarray:
    if colourspace is None:
        return a
    a = np.ascontiguousarray(a, dtype=np.float32)
    return convert_colourspace(a, colourspace, source, None if ocio is None else str(ocio))


def assert_images_close(
    actual: np.ndarray,
    expected: np.ndarray,
    psnr: Optional[float] = None,
    rmse: Optional[float] = None,
    peak: float = 1.0,
    diff: Optional[PathLike] = None,
    colourspace: Optional[str] = None,
    source: str = "",
    ocio: Optional[PathLike] = None,
) -> None:
    """Fail unless ``actual`` is close to ``expected``: PSNR ≥ ``psnr`` dB and/or RMSE ≤
    ``rmse`` (neither given: identical). Non-finite samples fail unless both arrays have the
    same ones. On failure the absolute difference is written as an EXR (``diff``, else a
    temporary file under ``$TYNDALL_DIFF_DIR``) and named in the message.

    ``colourspace``: compare in this colour space of config ``ocio`` (None: ``$OCIO``, else
    the built-in config), both arrays (H×W×3 or ×4) converted from ``source`` (empty: the
    working space) first; the PSNR, RMSE and difference are then those of the converted
    values. None (the default): compare the values as given."""
    if colourspace is not None:
        _pair(actual, expected)  # shapes first, with the usual message
        actual = _in_colourspace(actual, colourspace, source, ocio)
        expected = _in_colourspace(expected, colourspace, source, ocio)
    a, b = _pair(actual, expected)
    bad_a, bad_b = ~np.isfinite(a), ~np.isfinite(b)
    problems = []
    if not np.array_equal(bad_a, bad_b):
        problems.append(f"{int(np.sum(bad_a != bad_b))} samples finite in one and not the other")
    fa, fb = np.where(bad_a, 0.0, a), np.where(bad_b, 0.0, b)
    e = float(np.sqrt(np.mean((fa - fb) ** 2)))
    p = math.inf if e == 0.0 else 20.0 * math.log10(peak / e)
    if psnr is None and rmse is None and e != 0.0:
        problems.append(f"not identical (RMSE {e:.3g}, max |Δ| {float(np.max(np.abs(fa - fb))):.3g})")
    if psnr is not None and p < psnr:
        problems.append(f"PSNR {p:.2f} dB < {psnr} dB")
    if rmse is not None and e > rmse:
        problems.append(f"RMSE {e:.4g} > {rmse}")
    if problems:
        d = np.abs(fa - fb).astype(np.float32)
        if d.ndim == 3 and d.shape[2] == 4:
            d[..., 3] = 1.0
        path = _diff_path(diff)
        write_image(str(path), d)
        raise AssertionError("; ".join(problems) + f" — |actual − expected| written to {path}")


def assert_matches_golden(
    actual: np.ndarray,
    golden: PathLike,
    psnr: Optional[float] = None,
    rmse: Optional[float] = None,
    update: Optional[bool] = None,
    colourspace: Optional[str] = None,
    source: str = "",
    ocio: Optional[PathLike] = None,
) -> None:
    """Compare ``actual`` with the stored EXR ``golden`` (see :func:`assert_images_close`,
    whose ``colourspace``, ``source`` and ``ocio`` it passes on; the file stays as given).
    With ``update`` (default: ``$TYNDALL_UPDATE_GOLDEN`` is 1, which ``pytest --update-golden``
    sets) the file is written instead. A missing golden file fails, saying how to make it."""
    golden = Path(golden)
    if update is None:
        update = os.environ.get("TYNDALL_UPDATE_GOLDEN") == "1"
    actual = np.asarray(actual, dtype=np.float32)
    if update:
        golden.parent.mkdir(parents=True, exist_ok=True)
        write_image(str(golden), actual)
        return
    if not golden.exists():
        raise AssertionError(f"no golden image {golden}: run pytest with --update-golden to write it")
    expected = read_image(str(golden))
    if expected.ndim == 3 and actual.ndim == 3 and actual.shape[2] == 3:
        expected = expected[..., :3]
    diff = golden.with_name(golden.stem + ".diff.exr")
    assert_images_close(
        actual,
        expected,
        psnr=psnr,
        rmse=rmse,
        diff=diff,
        colourspace=colourspace,
        source=source,
        ocio=ocio,
    )
