"""What a misdeclared import leaves in the data, and the ``import`` flag it points to.

Two clues survive any calibration: a **constant ratio** between the angles the gyro integrates and the angles they
should be (the same on every axis: no triad's scale factors are all off by the same large factor, but a unit, a clock
or a nominal scale is), and **axes that fit a permutation** (the channel a rotation about body x shows up in is
another one, or its sign is flipped: the columns are mapped to the wrong axes). :func:`ratio_clue` and
:func:`permutation_clue` say, in words, which flag a ratio or a signed permutation points to; the importers and the
triad fit (:mod:`gyrojax.inference.triad_evidence`) both speak through them.
"""

from __future__ import annotations

import math

import numpy as np

DEG_PER_RAD = 180.0 / math.pi
CLOCK_FACTORS = {1e3: "ms", 1e6: "µs", 1e9: "ns"}
"""Ratios of a time unit to the second (a time column in ms read as s makes every duration 1000× too long)."""
CLOSE = 0.35
"""Distance in log (a factor 1.42) at which a ratio is taken for one of the named factors (57.3, 1000, …): the
factor times the gyro's own scale error (within 20 % for a MEMS gyro, 31 % for a nominal scale as far off as imu_tk's
Xsens start value) — the named factors lie 17× apart at least."""
MEMS_SCALE_BOUND = 0.2
"""Largest scale-factor error of a MEMS gyro (20 %, :data:`gyrojax.physics.plausibility.MEMS_PLAUSIBLE_MAX`)."""


def _near(r: float, f: float) -> bool:
    return abs(math.log(r / f)) < CLOSE


def ratio_clue(r: float) -> str:
    """The flags a common ratio ``r`` (dimensionless: integrated angle / true angle, or fitted scale / nominal)
    points to."""
    if not (r > 0 and math.isfinite(r)):
        return "check the gyro's unit (--gyro-unit), the nominal scale (--gyro-scale) and the clock (--rate-hz)"
    if _near(r, DEG_PER_RAD):
        return (
            f"the rates are {r:.4g}× too large, 180/π: deg/s declared as rad/s — check --gyro-unit (the data are "
            "probably in deg/s)"
        )
    if _near(r, 1.0 / DEG_PER_RAD):
        return (
            f"the rates are {1 / r:.4g}× too small, 180/π: rad/s declared as deg/s — check --gyro-unit (the data "
            "are probably in rad/s)"
        )
    for f, unit in CLOCK_FACTORS.items():
        if _near(r, f):
            return (
                f"every duration is {r:.4g}× too long: a time column in {unit} read as seconds — check --time-unit "
                f"(--time-unit {unit.replace('µ', 'u')})"
            )
        if _near(r, 1.0 / f):
            return f"every duration is {1 / r:.4g}× too short: check --time-unit (or --rate-hz)"
    if r > 1:
        what = f"the integrated angles are {r:.4g}× the true ones"
    else:
        what = f"the integrated angles are {r:.4g} of the true ones ({1 / r:.4g}× too small)"
    return (
        f"{what}, the same on every axis: the sample clock (--rate-hz, or --time-unit of a time column) or the "
        "nominal scale (--gyro-scale) is off by that factor"
    )


def signed_permutations() -> list[np.ndarray]:
    """The 48 signed permutation matrices (rows: body axes, columns: the data's channels), identity first."""
    import itertools

    out = []
    for perm in itertools.permutations(range(3)):
        for signs in itertools.product((1.0, -1.0), repeat=3):
            p = np.zeros((3, 3))
            for i, (j, s) in enumerate(zip(perm, signs)):
                p[i, j] = s
            out.append(p)
    out.sort(key=lambda p: (not np.allclose(p, np.eye(3)), -np.trace(p)))
    return out


def permutation_clue(p: np.ndarray, what: str = "gyro") -> str:
    """The ``--map`` a signed permutation ``p`` (body axis i = sign · data channel j) points to."""
    names = "xyz"
    parts = []
    for i in range(3):
        j = int(np.argmax(np.abs(p[i])))
        s = "-" if p[i, j] < 0 else ""
        if j != i or s:
            parts.append(f"body {names[i]} is {s}{what}_{names[j]}")
    return (
        f"the {what} channels fit a permutation of the body axes ({'; '.join(parts)}): the columns are mapped to "
        f"the wrong axes or with a flipped sign — check --map ({', '.join(f'{what}_{c}=…' for c in names)})"
    )
