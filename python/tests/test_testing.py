"""tyndall.testing: image assertions and golden files."""

import numpy as np
import pytest

import tyndall
from tyndall.testing import assert_images_close, assert_matches_golden, psnr


def test_close_images_pass_and_different_ones_fail_with_a_diff(tmp_path):
    a = np.zeros((4, 4, 4), dtype=np.float32)
    b = a.copy()
    b[0, 0, 0] = 0.01
    assert_images_close(a, a)
    assert_images_close(a, b, psnr=40)
    assert psnr(a, b) == pytest.approx(20 * np.log10(1 / np.sqrt(0.01**2 / 64)))
    diff = tmp_path / "d.exr"
    with pytest.raises(AssertionError) as e:
        assert_images_close(a, b, rmse=1e-4, diff=diff)
    assert "RMSE" in str(e.value) and str(diff) in str(e.value)
    d = tyndall.read_image(diff)
    assert d[0, 0, 0] == pytest.approx(0.01)
    with pytest.raises(AssertionError):
        assert_images_close(a, np.zeros((4, 5, 4)))


def test_golden_files_are_written_then_compared(tmp_path):
    img = np.random.default_rng(1).random((6, 8, 4)).astype(np.float32)
    golden = tmp_path / "g.exr"
    with pytest.raises(AssertionError, match="--update-golden"):
        assert_matches_golden(img, golden)
    assert_matches_golden(img, golden, update=True)
    assert_matches_golden(img, golden)
    with pytest.raises(AssertionError):
        assert_matches_golden(img * 0.5, golden, psnr=60)
    assert (tmp_path / "g.diff.exr").is_file()
