import json
from pathlib import Path

import jax
import pytest

jax.config.update("jax_enable_x64", True)

SHARED = Path(__file__).resolve().parents[1].parent / "shared"
EXAMPLES = SHARED / "examples"


def examples_available() -> bool:
    return (EXAMPLES / "examples.json").exists()


@pytest.fixture(scope="session")
def example_campaigns():
    if not examples_available():
        pytest.skip(f"shared examples not found at {EXAMPLES}")
    return json.loads((EXAMPLES / "examples.json").read_text())
