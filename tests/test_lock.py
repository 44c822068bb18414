"""The lock (constraints.txt) that `make test` and `make demo` install from covers every declared dependency."""

import tomllib
from pathlib import Path

from packaging.requirements import Requirement
from packaging.utils import canonicalize_name
from packaging.version import Version

ROOT = Path(__file__).resolve().parent.parent


def _lock() -> dict:
    pins = {}
    for n, line in enumerate((ROOT / "constraints.txt").read_text().splitlines(), 1):
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        name, sep, version = line.partition("==")
        assert sep, f"constraints.txt:{n}: {line!r} is not an exact pin NAME==VERSION"
        pins[canonicalize_name(name)] = Version(version)
    return pins


def test_every_dependency_and_extra_is_pinned_within_its_declared_range():
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    declared = list(project["dependencies"])
    for extra in project["optional-dependencies"].values():
        declared += extra
    pins = _lock()
    for spec in declared:
        req = Requirement(spec)
        name = canonicalize_name(req.name)
        assert name in pins, f"{req.name} is declared in pyproject.toml but not pinned in constraints.txt (make lock)"
        assert req.specifier.contains(pins[name], prereleases=True), (
            f"constraints.txt pins {req.name}=={pins[name]}, outside pyproject.toml's {req.specifier}"
        )


def test_the_makefile_installs_from_the_lock():
    make = (ROOT / "Makefile").read_text()
    assert "LOCK   := constraints.txt" in make
    install_lines = [ln for ln in make.splitlines() if "$(PY) -m pip install" in ln]
    assert install_lines and all("-c $(LOCK)" in ln for ln in install_lines), install_lines
