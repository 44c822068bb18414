"""Truth files: what a simulation is told is true (conventions §8).

gyrojax writes them in the result protocol of :mod:`gyrojax.protocol` (:func:`save_truth`: format tag
``"gyrojax-truth"``, integer ``format_version``); a truth file without the tag, as other tools and hand-written
files have it, loads too.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gyrojax import protocol
from gyrojax.errors import TruthError
from gyrojax.noise.spec import NoiseSpec
from gyrojax.physics import effects as fx
from gyrojax.protocol import is_finite_number, read_json_file

SETUP_SIZES = {"table_tilt": 2, "table_azimuth": 1, "encoder_harmonic": 4}
TRUTH_FORMAT = "gyrojax-truth"
TRUTH_VERSION = 1


@dataclass(frozen=True)
class Truth:
    """Coefficients (report units, by coefficient name), set-up errors (by set-up effect name) and noise (the one
    noise description, :class:`~gyrojax.noise.spec.NoiseSpec`; a truth file's ``noise`` dict of conventions §8 on
    disk)."""

    coefficients: dict = field(default_factory=dict)
    setup: dict = field(default_factory=dict)
    noise: NoiseSpec = field(default_factory=NoiseSpec)

    def __post_init__(self):
        if not isinstance(self.noise, NoiseSpec):  # a truth file's noise dict (conventions §8)
            object.__setattr__(self, "noise", NoiseSpec.from_truth(self.noise, "truth: noise"))

    def all_coefficients(self) -> dict:
        """Instrument and set-up coefficients together, by coefficient name."""
        out = dict(self.coefficients)
        for name, vals in self.setup.items():
            for c, v in zip(fx.get(name).coefficients, np.atleast_1d(vals)):
                out[c] = float(v)
        return out

    def to_dict(self) -> dict:
        """The truth as a JSON-ready dict (conventions §8; coefficients in report units)."""
        return {
            "coefficients": dict(self.coefficients),
            "setup": {k: (list(v) if np.ndim(v) else v) for k, v in self.setup.items()},
            "noise": self.noise.to_truth(),
        }


def truth_from_dict(d, where: str = "truth") -> Truth:
    """Validate a truth dict; unknown names are errors naming the key."""
    if not isinstance(d, dict):
        raise TruthError(f"{where}: the top level must be an object")
    if protocol.FORMAT_KEY in d or protocol.VERSION_KEY in d:  # written by save_truth; untagged files load too
        protocol.check_as(d, TRUTH_FORMAT, TRUTH_VERSION, where, TruthError)
    for k in d:
        if k not in ("coefficients", "setup", "noise", protocol.FORMAT_KEY, protocol.VERSION_KEY):
            raise TruthError(f"{where}: unknown key {k!r}; valid: 'coefficients', 'setup', 'noise'")
    idx = fx.coefficient_index()
    coeffs = {}
    setup_coeffs = {c for e in SETUP_SIZES for c in fx.get(e).coefficients}
    for part in ("coefficients", "setup", "noise"):
        if d.get(part) is not None and not isinstance(d[part], dict):
            raise TruthError(f"{where}: key {part!r} must be an object of name: value, got {type(d[part]).__name__}")
    for k, v in (d.get("coefficients") or {}).items():
        if k not in idx:
            raise TruthError(
                f"{where}: key {'coefficients.' + str(k)!r} is not a coefficient name; valid: {', '.join(idx)}"
            )
        if k in setup_coeffs:
            raise TruthError(f"{where}: key {'coefficients.' + str(k)!r} is a set-up error; give it under 'setup'")
        if not is_finite_number(v):
            raise TruthError(f"{where}: key {'coefficients.' + str(k)!r} must be a finite number, got {v!r}")
        coeffs[k] = float(v)
    setup = {}
    for k, v in (d.get("setup") or {}).items():
        if k not in SETUP_SIZES:
            raise TruthError(f"{where}: key {'setup.' + str(k)!r} unknown; valid: {', '.join(SETUP_SIZES)}")
        try:
            flat = v if isinstance(v, list) else [v]
            if not all(is_finite_number(x) for x in flat):
                raise ValueError
            arr = np.asarray(flat, dtype=float)
        except (TypeError, ValueError, OverflowError):
            arr = np.zeros(0)
        if arr.size != SETUP_SIZES[k] or not np.all(np.isfinite(arr)):
            raise TruthError(
                f"{where}: key {'setup.' + str(k)!r} needs {SETUP_SIZES[k]} finite number(s) in arcsec, got {v!r}"
            )
        setup[k] = tuple(float(x) for x in arr)
    for k, v in (d.get("noise") or {}).items():  # numbers only (NoiseSpec.from_truth names the valid terms)
        vals = v if isinstance(v, (list, tuple)) and k in ("gauss_markov", "bias_instability") else [v]
        if not all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in vals):
            raise TruthError(f"{where}: key {'noise.' + str(k)!r} must hold numbers (conventions §8 units), got {v!r}")
    try:
        noise = NoiseSpec.from_truth(d.get("noise"), f"{where}: noise")
    except TruthError:
        raise
    except (TypeError, ValueError, OverflowError) as e:
        raise TruthError(f"{where}: key 'noise' is invalid ({e}); see conventions §8") from None
    return Truth(coeffs, setup, noise)


def load_truth(path) -> Truth:
    """Load and validate a truth file (conventions §8) from a JSON file (errors name the file and the key)."""
    return truth_from_dict(read_json_file(path, TruthError, "a truth file (conventions §8)"), str(path))


def save_truth(truth: Truth, path, force: bool = False) -> Path:
    """Write ``truth`` to ``path`` (tagged ``TRUTH_FORMAT``, strict JSON, atomically; an existing file only with
    ``force``); :func:`load_truth` reads it back equal. Returns the path."""
    return protocol.save(path, truth.to_dict(), TRUTH_FORMAT, TRUTH_VERSION, force=force)
