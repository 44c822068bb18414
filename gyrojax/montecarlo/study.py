"""Monte Carlo study files: the :class:`Study` a study JSON describes and its validation.

A study names a built-in plan, the fitted terms, the priors of the coefficients and set-up errors, the noise and
the number of draws (docs/montecarlo.md); ``instrument`` ``imu-triad`` makes it a hand calibration session of a MEMS
gyro triad (:data:`TRIAD_SESSIONS`, :mod:`gyrojax.montecarlo.triad`). :func:`study_from_dict` checks a study dict
and names the offending key; the draws are made by :mod:`gyrojax.montecarlo.pipeline`, run by
:mod:`gyrojax.montecarlo.runner` and kept in a :class:`~gyrojax.montecarlo.results.StudyResult`.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from pathlib import Path

from gyrojax import protocol
from gyrojax.data import plans as plans_mod
from gyrojax.data.truth import SETUP_SIZES
from gyrojax.errors import GyrojaxError
from gyrojax.noise.spec import NoiseModelError, NoiseSpec
from gyrojax.physics import effects as fx
from gyrojax.physics.model import Model
from gyrojax.physics.triad import channel_model
from gyrojax.protocol import read_json_file

STUDY_FORMAT = "gyrojax-mc-study"
STUDY_VERSION = 1
STUDY_LEGACY = {"gyrojax-mc-study-1": (STUDY_FORMAT, 1)}
"""Format strings of study files written before the result protocol, and the version they stand for."""
INSTRUMENTS = ("turntable", "imu-triad")
"""The instruments a study simulates: a gyro on a turntable (the default) or a MEMS gyro triad by hand."""
TRIAD_SESSIONS = ("ferraris", "multiposition", "protocol")
"""The sessions of an imu-triad study: Ferraris', imu_tk's random poses with moves, a designed protocol's steps."""
SDF_NINE_TERMS = ("D_F", "D_I", "D_O", "D_S", "D_II", "D_SS", "D_IO", "D_IS", "D_OS")
"""The SDF drift model less D_OO: in a 1 g test a_I² + a_O² + a_S² = 1, so D_F, D_II, D_OO, D_SS are aliased."""


class StudyError(GyrojaxError, ValueError):
    """A Monte Carlo study definition is malformed (the message names the key)."""


@dataclass(frozen=True)
class Study:
    """A Monte Carlo study (JSON-serialisable; :meth:`to_dict` / :func:`study_from_dict`).

    ``priors`` and ``setup`` map a coefficient name (or an effect name: every coefficient of it) to a prior:
    a number (fixed), ``{"normal": [mean, std]}`` or ``{"uniform": [low, high]}``, report units (arcsec for the
    set-up errors). ``noise`` is a :class:`~gyrojax.noise.spec.NoiseSpec` (in the study file, a truth file's
    noise dict of conventions §8, e.g. ``{"white": 0.01}``).
    """

    plan: str
    terms: tuple[str, ...]
    priors: dict = field(default_factory=dict)
    setup: dict = field(default_factory=dict)
    noise: NoiseSpec = field(default_factory=NoiseSpec)
    draws: int = 1000
    seed: int = 0
    plan_options: dict = field(default_factory=dict)
    kind: str = fx.SDF
    chunk: int | None = None
    solver: str = "cholesky"
    instrument: str = INSTRUMENTS[0]

    def __post_init__(self):
        if isinstance(self.noise, dict) and protocol.FORMAT_KEY in self.noise:  # a saved noise model
            object.__setattr__(self, "noise", NoiseSpec.from_json(self.noise, where="study: key 'noise'"))
        elif not isinstance(self.noise, NoiseSpec):  # a truth file's noise dict (conventions §8), as in study files
            object.__setattr__(self, "noise", NoiseSpec.from_truth(self.noise, "study: key 'noise'"))

    def to_dict(self) -> dict:
        """The study as a JSON-ready dict (the study file format, ``STUDY_FORMAT`` version ``STUDY_VERSION``)."""
        d = asdict(self)
        if self.instrument == INSTRUMENTS[0]:  # the default, left out: turntable study files stay as they were
            del d["instrument"]
        d["terms"] = list(self.terms)
        # a truth dict when the noise is one (conventions §8); otherwise (e.g. two Gauss–Markov terms from
        # gyrojax noise) the saved noise model, tagged
        try:
            d["noise"] = self.noise.to_truth()
        except NoiseModelError:
            d["noise"] = self.noise.to_json()
        d[protocol.FORMAT_KEY] = STUDY_FORMAT
        d[protocol.VERSION_KEY] = STUDY_VERSION
        return d

    def to_json(self) -> str:
        """The study file text (strict JSON of :meth:`to_dict`, ``format``/``format_version`` first)."""
        return protocol.dumps(self.to_dict(), STUDY_FORMAT, STUDY_VERSION)


_STUDY_KEYS = (
    "format",
    "format_version",
    "plan",
    "plan_options",
    "terms",
    "priors",
    "setup",
    "noise",
    "draws",
    "seed",
    "kind",
    "chunk",
    "solver",
    "instrument",
)


def parse_prior(v, where: str):
    """(is_uniform, a, b) of a prior: number → N(v, 0); {"normal": [μ, σ]}; {"uniform": [lo, hi]}."""
    if isinstance(v, bool):
        raise StudyError(f"{where}: a prior must be a number or {{'normal': [mean, std]}} / {{'uniform': [lo, hi]}}")
    if isinstance(v, (int, float)):
        if not math.isfinite(v):
            raise StudyError(f"{where}: must be finite, got {v!r}")
        return False, float(v), 0.0
    if not isinstance(v, dict) or len(v) != 1 or next(iter(v)) not in ("normal", "uniform"):
        raise StudyError(
            f"{where}: a prior must be a number or {{'normal': [mean, std]}} / {{'uniform': [lo, hi]}}, got {v!r}"
        )
    ((k, ab),) = v.items()
    if (
        not isinstance(ab, (list, tuple))
        or len(ab) != 2
        or not all(isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) for x in ab)
    ):
        raise StudyError(f"{where}.{k}: needs two finite numbers, got {ab!r}")
    a, b = float(ab[0]), float(ab[1])
    if k == "normal" and b < 0:
        raise StudyError(f"{where}.normal: std must be >= 0, got {b}")
    if k == "uniform" and b < a:
        raise StudyError(f"{where}.uniform: needs low <= high, got {ab!r}")
    return k == "uniform", a, b


def expand_name(name: str, where: str, setup: bool) -> tuple[str, ...]:
    """Coefficient names of a prior key (a coefficient, or an effect = all its coefficients)."""
    idx = fx.coefficient_index()
    if name in fx.names():
        eff = fx.get(name)
        coeffs = eff.coefficients
    elif name in idx:
        eff = fx.get(fx.effect_of_coefficient(name))
        coeffs = (name,)
    else:
        raise StudyError(f"{where}: key {name!r} is neither an effect nor a coefficient name")
    if setup and eff.name not in SETUP_SIZES:
        raise StudyError(f"{where}: key {name!r} is not a set-up error; valid: {', '.join(SETUP_SIZES)}")
    if not setup and eff.name in SETUP_SIZES:
        raise StudyError(f"{where}: key {name!r} is a set-up error; give its prior under 'setup'")
    return coeffs


def study_from_dict(d, where: str = "study") -> Study:
    """Validate a study dict; every error names the offending key."""
    if not isinstance(d, dict):
        raise StudyError(f"{where}: the top level must be an object")
    for k in d:
        if k not in _STUDY_KEYS:
            raise StudyError(f"{where}: unknown key {k!r}; valid: {', '.join(_STUDY_KEYS)}")
    if protocol.FORMAT_KEY in d or protocol.VERSION_KEY in d:  # a hand-written study may leave the tag out
        protocol.check_as(d, STUDY_FORMAT, STUDY_VERSION, where, StudyError, STUDY_LEGACY)
    if "plan" not in d:
        raise StudyError(f"{where}: missing required key 'plan' (a built-in plan name)")
    instrument = d.get("instrument", INSTRUMENTS[0])
    if instrument not in INSTRUMENTS:
        raise StudyError(f"{where}: key 'instrument' = {instrument!r}; valid: {', '.join(INSTRUMENTS)}")
    plans = plans_mod.BUILDERS if instrument == INSTRUMENTS[0] else TRIAD_SESSIONS
    if d["plan"] not in plans:
        raise StudyError(f"{where}: key 'plan' = {d['plan']!r}; {instrument} plans: {', '.join(plans)}")
    opts = d.get("plan_options") or {}
    if not isinstance(opts, dict):
        raise StudyError(f"{where}: key 'plan_options' must be an object")
    terms = d.get("terms")
    if not isinstance(terms, (list, tuple)) or not terms or not all(isinstance(t, str) for t in terms):
        raise StudyError(f"{where}: key 'terms' must be a non-empty list of effect names")
    kind = d.get("kind", fx.SDF)
    if kind not in (fx.SDF, fx.TDF, fx.ACCEL):
        raise StudyError(f"{where}: key 'kind' = {kind!r}; valid: {fx.SDF}, {fx.TDF}, {fx.ACCEL}")
    try:
        Model.of(terms, kind) if instrument == INSTRUMENTS[0] else channel_model(terms)
    except GyrojaxError as e:
        raise StudyError(f"{where}: key 'terms': {e}") from None
    for key, setup in (("priors", False), ("setup", True)):
        pr = d.get(key) or {}
        if not isinstance(pr, dict):
            raise StudyError(f"{where}: key {key!r} must be an object")
        for name, v in pr.items():
            if instrument == INSTRUMENTS[0]:
                expand_name(name, f"{where}: key '{key}.{name}'", setup)
            parse_prior(v, f"{where}: key '{key}.{name}'")
    try:
        nd = d.get("noise")
        if isinstance(nd, dict) and protocol.FORMAT_KEY in nd:  # a saved noise model (e.g. two Gauss–Markov terms)
            noise = NoiseSpec.from_json(nd, where=f"{where}: key 'noise'")
        else:
            noise = NoiseSpec.from_truth(nd, f"{where}: key 'noise'")
    except GyrojaxError as e:
        raise StudyError(str(e)) from None
    for key in ("draws", "seed", "chunk"):
        v = d.get(key)
        if v is None and key != "draws":
            continue
        if key == "draws" and v is None:
            v = 1000
        if isinstance(v, bool) or not isinstance(v, int) or v < (0 if key == "seed" else 1):
            raise StudyError(f"{where}: key {key!r} must be an integer >= {0 if key == 'seed' else 1}, got {v!r}")
    solver = d.get("solver", "cholesky")
    if solver not in ("cholesky", "qr"):
        raise StudyError(f"{where}: key 'solver' = {solver!r}; valid: cholesky, qr")
    return Study(
        plan=d["plan"],
        terms=tuple(terms),
        priors=dict(d.get("priors") or {}),
        setup=dict(d.get("setup") or {}),
        noise=noise,
        draws=int(d.get("draws", 1000)),
        seed=int(d.get("seed", 0)),
        plan_options=dict(opts),
        kind=kind,
        chunk=d.get("chunk"),
        solver=solver,
        instrument=instrument,
    )


def load_study(path) -> Study:
    """Load and validate a study from a JSON file (errors name the file and the key)."""
    return study_from_dict(read_json_file(path, StudyError, "a study"), str(path))


def save_study(study: Study, path, force: bool = False) -> Path:
    """Write ``study`` to ``path`` (strict JSON, atomically; an existing file only with ``force``);
    :func:`load_study` reads it back equal. Returns the path."""
    return protocol.save(path, study.to_dict(), STUDY_FORMAT, STUDY_VERSION, force=force)
