"""The pytest plugin of the ``tyndall`` package (registered through the ``pytest11`` entry
point): ``--update-golden`` writes golden images instead of comparing them, and the
``golden_update`` fixture says whether it was given."""

from __future__ import annotations

import os

import pytest


def pytest_addoption(parser):
    parser.addoption(
        "--update-golden",
        action="store_true",
        default=False,
        help="tyndall.testing: write golden images instead of comparing with them",
    )


def pytest_configure(config):
    if config.getoption("--update-golden", default=False):
        os.environ["TYNDALL_UPDATE_GOLDEN"] = "1"


@pytest.fixture
def golden_update(request) -> bool:
    """Whether pytest runs with --update-golden."""
    return bool(request.config.getoption("--update-golden"))
