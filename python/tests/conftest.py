"""Shared fixtures: the repository root (tests run from anywhere) and the CLI binary."""

import os
import pathlib
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]


@pytest.fixture
def root() -> pathlib.Path:
    return ROOT


@pytest.fixture
def cli():
    """Run the `tyndall` binary ($TYNDALL_BIN, else target/debug/tyndall); returns the result."""
    binary = os.environ.get("TYNDALL_BIN", str(ROOT / "target" / "debug" / "tyndall"))

    def run(*args):
        return subprocess.run([binary, *map(str, args)], capture_output=True, text=True, cwd=ROOT)

    return run
