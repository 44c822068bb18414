"""Truth files: what a simulation is told is true (conventions §8).

gyrojax writes them in the result protocol of :mod:`gyrojax.protocol` (:func:`save_truth`: format tag
``"gyrojax-truth"``, integer ``format_version``); a truth file without the tag, as other tools and hand-written
files have it, loads too.

**A hand-held triad's truth** (an extension of §8 that renames nothing in it): ``"kind": "imu-triad"`` (the
instrument kind of the records, conventions §9.3) makes the file a :class:`TriadTruth`. Its ``coefficients`` are
per-channel (``D_F[x]``, ``E_SF[y]``, ``M_O[z]``; units of §6); ``setup`` is refused (a person turning a box has no
table); ``noise`` holds ``white``, the gyro channels' angle random walk N (deg/√h; a sample at r Hz has σ =
60 N √r / 3600 deg/s, IEEE 952), the only noise a simulated hand session draws; ``session`` the simulated sessions'
sampling and hand (:data:`SESSION_KEYS`). A file without ``kind`` is a turntable truth, read as before.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gyrojax import protocol
from gyrojax.errors import ModelError, TruthError
from gyrojax.noise.spec import NoiseSpec
from gyrojax.physics import effects as fx
from gyrojax.physics import triad as tp
from gyrojax.protocol import is_finite_number, read_json_file

SETUP_SIZES = {"table_tilt": 2, "table_azimuth": 1, "encoder_harmonic": 4}
TRIAD_KIND = "imu-triad"
SESSION_KEYS = {
    "rate_hz": 100.0,
    "acc_noise_g": 0.002,
    "placement_deg": 0.0,
    "latitude_deg": 49.6,
    "earth_rate": True,
}
"""A triad truth's ``session`` keys and defaults (those of :func:`gyrojax.simulation.triad_session.simulate_session`):
the sample rate (Hz), the accelerometers' white noise (g per sample), σ of the hand's placement about each body axis
(deg), the site's latitude (deg; the records leave it unknown, as a hand session's) and whether the Earth turns."""
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


@dataclass(frozen=True)
class TriadTruth:
    """A hand-held MEMS triad's truth (module doc): per-channel ``coefficients`` (report units, ``D_F[x]`` …), the
    gyro's ARW ``arw`` (deg/√h) and the simulated sessions' options ``session`` (:data:`SESSION_KEYS`)."""

    coefficients: dict = field(default_factory=dict)
    arw: float = 0.0
    session: dict = field(default_factory=dict)

    @property
    def terms(self) -> tuple:
        """The effects the truth's coefficients belong to, in the registry's order (what a session simulates)."""
        idx = fx.coefficient_index()
        present = {idx[tp.split_channel_name(c)[0]][0] for c in self.coefficients}
        return tuple(e for e in fx.names() if e in present)

    def gyro_noise_dps(self) -> float:
        """σ of one gyro sample (deg/s) at the session's rate: 60 N √r / 3600 (IEEE 952, N in deg/√h)."""
        return self.arw * 60.0 * math.sqrt(self.session_options()["rate_hz"]) / 3600.0

    def session_options(self) -> dict:
        """The session's options with their defaults (:data:`SESSION_KEYS`)."""
        return {**SESSION_KEYS, **self.session}

    def simulation_options(self) -> dict:
        """The keyword arguments of :func:`~gyrojax.simulation.triad_session.simulate_session` for this truth."""
        return {**self.session_options(), "gyro_noise_dps": self.gyro_noise_dps(), "terms": self.terms or ("D_F",)}

    def to_dict(self) -> dict:
        """The truth as a JSON-ready dict (module doc)."""
        return {
            "kind": TRIAD_KIND,
            "coefficients": dict(self.coefficients),
            "noise": {"white": self.arw},
            "session": dict(self.session),
        }


def triad_truth_from_dict(d: dict, where: str = "truth") -> TriadTruth:
    """Validate a triad truth dict (module doc); errors name the key."""
    for k in d:
        if k not in ("kind", "coefficients", "noise", "session", protocol.FORMAT_KEY, protocol.VERSION_KEY):
            hint = " (a hand session has no table)" if k == "setup" else ""
            raise TruthError(
                f"{where}: key {k!r} is not a key of an imu-triad truth{hint}; valid: 'kind', 'coefficients', "
                "'noise', 'session'"
            )
    for part in ("coefficients", "noise", "session"):
        if d.get(part) is not None and not isinstance(d[part], dict):
            raise TruthError(f"{where}: key {part!r} must be an object of name: value, got {type(d[part]).__name__}")
    idx = fx.coefficient_index()
    coeffs = {}
    for k, v in (d.get("coefficients") or {}).items():
        try:
            base, _ = tp.split_channel_name(str(k))
        except ModelError as e:
            raise TruthError(f"{where}: key {'coefficients.' + str(k)!r}: {e}") from None
        if base not in idx:
            raise TruthError(f"{where}: key {'coefficients.' + str(k)!r}: {base!r} is not a coefficient name")
        if not is_finite_number(v):
            raise TruthError(f"{where}: key {'coefficients.' + str(k)!r} must be a finite number, got {v!r}")
        coeffs[str(k)] = float(v)
    noise = dict(d.get("noise") or {})
    other = [k for k in noise if k != "white"]
    if other:
        raise TruthError(
            f"{where}: key {'noise.' + other[0]!r}: a simulated hand session draws white gyro noise only; give "
            "'white' (ARW, deg/sqrt(h))"
        )
    arw = noise.get("white", 0.0)
    if not (is_finite_number(arw) and arw >= 0):
        raise TruthError(f"{where}: key 'noise.white' must be a finite number >= 0 (deg/sqrt(h)), got {arw!r}")
    session = {}
    for k, v in (d.get("session") or {}).items():
        if k not in SESSION_KEYS:
            raise TruthError(f"{where}: key {'session.' + str(k)!r} unknown; valid: {', '.join(SESSION_KEYS)}")
        if k == "earth_rate":
            if not isinstance(v, bool):
                raise TruthError(f"{where}: key 'session.earth_rate' must be true or false, got {v!r}")
        elif not is_finite_number(v) or (k != "latitude_deg" and v < 0) or (k == "rate_hz" and v <= 0):
            raise TruthError(f"{where}: key {'session.' + k!r} must be a finite number (> 0 for a rate), got {v!r}")
        session[k] = v if isinstance(v, bool) else float(v)
    out = TriadTruth(coeffs, float(arw), session)
    try:
        tp.channel_model(out.terms or ("D_F",))
    except ModelError as e:
        raise TruthError(f"{where}: key 'coefficients': {e}") from None
    return out


def truth_from_dict(d, where: str = "truth") -> Truth | TriadTruth:
    """Validate a truth dict; unknown names are errors naming the key. ``"kind": "imu-triad"`` gives a
    :class:`TriadTruth` (module doc), no ``kind`` a turntable :class:`Truth`."""
    if not isinstance(d, dict):
        raise TruthError(f"{where}: the top level must be an object")
    if protocol.FORMAT_KEY in d or protocol.VERSION_KEY in d:  # written by save_truth; untagged files load too
        protocol.check_as(d, TRUTH_FORMAT, TRUTH_VERSION, where, TruthError)
    if "kind" in d:
        if d["kind"] != TRIAD_KIND:
            raise TruthError(
                f"{where}: key 'kind' is {d['kind']!r}; a truth names only {TRIAD_KIND!r} (a turntable truth has no "
                "kind: the plan's records name the instrument)"
            )
        return triad_truth_from_dict(d, where)
    for k in d:
        if k not in ("coefficients", "setup", "noise", protocol.FORMAT_KEY, protocol.VERSION_KEY):
            raise TruthError(f"{where}: unknown key {k!r}; valid: 'coefficients', 'setup', 'noise', 'kind'")
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


def load_truth(path) -> Truth | TriadTruth:
    """Load and validate a truth file (conventions §8) from a JSON file (errors name the file and the key)."""
    return truth_from_dict(read_json_file(path, TruthError, "a truth file (conventions §8)"), str(path))


def save_truth(truth: Truth | TriadTruth, path, force: bool = False) -> Path:
    """Write ``truth`` to ``path`` (tagged ``TRUTH_FORMAT``, strict JSON, atomically; an existing file only with
    ``force``); :func:`load_truth` reads it back equal. Returns the path."""
    return protocol.save(path, truth.to_dict(), TRUTH_FORMAT, TRUTH_VERSION, force=force)
