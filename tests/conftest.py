import json
from pathlib import Path

import pytest

import gyrojax  # noqa: F401  (x64 is switched on by the package, once)
from gyrojax.cli.app import single_threaded_blas

single_threaded_blas()  # two test workers on two cores: BLAS threads would only spin against each other

DATA = Path(__file__).resolve().parent / "data"
EXAMPLES = DATA / "examples"
"""Campaigns written by an independent tool, vendored (tests/data/README.md)."""
IMUCAL = DATA / "imucal"
"""A real MEMS-IMU session and imucal's calibration of it (MIT), vendored."""


@pytest.fixture(scope="session")
def example_campaigns():
    return json.loads((EXAMPLES / "examples.json").read_text())
