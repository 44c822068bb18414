"""Test plans as data (arrays to differentiate and vmap), and the classical procedures of Hu ch. 3 as plan builders.

A :class:`Plan` is a site and a sequence of :class:`Run` s; each run becomes one record. A run is a table
geometry, an instrument mounting, a mode (rebalance or servo) and a sequence of :class:`Segment` s; a segment
moves every table axis as θ(t) = θ_0 + θ̇·t + A·sin(2π f t) for ``duration_s`` at ``dt_s``. Static positions,
constant rates, continuous tumbles and oscillations are all segments. Between segments the table moves
unlogged for ``gap_s`` seconds, which ends a continuous segment in the record (conventions §5).

Every builder cites its seed procedure. Plan files (JSON) are :mod:`gyrojax.data.planfile`; ``gyrojax simulate
PLAN`` takes a builder name or such a file.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from gyrojax import units
from gyrojax.data.record import FORMAT
from gyrojax.data.schema import validate_meta
from gyrojax.errors import PlanError, RecordError
from gyrojax.protocol import is_finite_number

DEFAULT_LATITUDE = 39.98  # Beijing, the site of the example campaigns


@dataclass(frozen=True)
class Segment:
    """One piece of table motion (angles in deg, rates in deg/s, time in s)."""

    start_deg: tuple[float, ...]
    duration_s: float
    dt_s: float = 1.0
    rate_dps: tuple[float, ...] | None = None
    amplitude_deg: tuple[float, ...] | None = None
    frequency_hz: float = 0.0
    label: int | None = None

    def samples(self):
        """(t since segment start, angles (n,k) deg, rates (n,k) deg/s)."""
        n = max(1, int(round(self.duration_s / self.dt_s)))
        t = np.arange(n) * self.dt_s
        k = len(self.start_deg)
        rate = np.zeros(k) if self.rate_dps is None else np.asarray(self.rate_dps, float)
        amp = np.zeros(k) if self.amplitude_deg is None else np.asarray(self.amplitude_deg, float)
        w = 2 * math.pi * self.frequency_hz
        ang = np.asarray(self.start_deg, float) + np.outer(t, rate) + np.outer(np.sin(w * t), amp)
        rates = rate + np.outer(np.cos(w * t), amp * w)
        return t, ang, rates


@dataclass(frozen=True)
class Run:
    """One record's worth of testing: a table, a mounting, a mode and its segments."""

    name: str
    axes: tuple[tuple[str, tuple[float, float, float]], ...]
    instrument: dict
    segments: tuple[Segment, ...]
    mode: str = "rebalance"
    servo_axis: str | None = None
    scale_factor: float = 17.171  # deg/h/mA (g/mA for accelerometers)
    gap_s: float = 30.0
    temperature_C: float | None = None

    @property
    def duration_s(self) -> float:
        """Length of the run in s: its segments plus the gaps between them."""
        return sum(s.duration_s for s in self.segments) + self.gap_s * (len(self.segments) - 1)


@dataclass(frozen=True)
class Plan:
    """A test campaign: site, runs, and where it comes from."""

    name: str
    runs: tuple[Run, ...]
    latitude_deg: float = DEFAULT_LATITUDE
    gravity_mps2: float | None = None
    description: str = ""
    reference: str = ""
    gap_between_runs_s: float = 60.0

    @property
    def duration_s(self) -> float:
        """Length of the campaign in s: its runs plus the gaps between them."""
        return sum(r.duration_s for r in self.runs) + self.gap_between_runs_s * (len(self.runs) - 1)


# ---- geometry helpers -----------------------------------------------------------------------------------------

E, N, U = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)


def polar_axis(latitude_deg: float) -> tuple[float, float, float]:
    """Unit vector of the Earth's rotation axis in ENU: (0, cos φ, sin φ), φ = ``latitude_deg`` (deg)."""
    p = math.radians(latitude_deg)
    return (0.0, math.cos(p), math.sin(p))


def sdf_mount(ia, oa) -> dict:
    """SDF instrument dict with SA = IA × OA (conventions §4)."""
    ia, oa = np.asarray(ia, float), np.asarray(oa, float)
    ia, oa = ia / np.linalg.norm(ia), oa / np.linalg.norm(oa)
    if abs(ia @ oa) > 1e-9:
        raise PlanError(f"IA {ia.tolist()} and OA {oa.tolist()} are not orthogonal")
    return {"kind": "sdf-gyro", "ia": _clean(ia), "oa": _clean(oa), "sa": _clean(np.cross(ia, oa))}


def tdf_mount(x, y) -> dict:
    """TDF gyro instrument dict with spin axis Z = X × Y (conventions §4); axes are unit vectors in platform
    coordinates."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    return {"kind": "tdf-gyro", "x": _clean(x), "y": _clean(y), "z": _clean(np.cross(x, y))}


def accel_mount(ia, pa) -> dict:
    """Pendulous accelerometer instrument dict with OA = IA × PA (conventions §4); unit vectors in platform
    coordinates."""
    ia, pa = np.asarray(ia, float), np.asarray(pa, float)
    return {"kind": "pendulous-accel", "ia": _clean(ia), "pa": _clean(pa), "oa": _clean(np.cross(ia, pa))}


def _clean(v) -> list[float]:
    return [0.0 if abs(x) < 1e-15 else float(x) for x in v]


SKEW_MOUNT = sdf_mount((0.0, 1.0, 1.0), (1.0, 1.0, -1.0))
"""A skew mounting in platform coordinates: every instrument axis has components on all three table axes."""

TWO_AXIS = (("trunnion", E), ("platform", U))
"""Two-axis table: outer trunnion East, inner axis normal to the platform (Up at zero angles)."""

# ---- builders -------------------------------------------------------------------------------------------------


def fixed_position(hours: float = 1.0, dt_s: float = 1.0, ia=E, oa=N, latitude_deg=DEFAULT_LATITUDE) -> Plan:
    """Fixed-position drift test: one orientation held for ``hours`` (Hu ch. 3 §2)."""
    run = Run("fixed", (("base", U),), sdf_mount(ia, oa), (Segment((0.0,), hours * 3600.0, dt_s),))
    return Plan("fixed", (run,), latitude_deg, description="fixed-position test", reference="Hu ch. 3 §2")


HU_EIGHT_POSITIONS = (
    # (x, y, z) directions in ENU of Hu's positions 1–8 (Hu 3-1 to 3-9, figs 3-2 to 3-9);
    # x outer gimbal, y inner gimbal, z spin.  Position 7 of the text has x down, y west, z north.
    (E, N, U),
    (N, (-1.0, 0.0, 0.0), U),
    ((-1.0, 0.0, 0.0), (0.0, -1.0, 0.0), U),
    ((0.0, -1.0, 0.0), E, U),
    (U, E, N),
    ((-1.0, 0.0, 0.0), U, N),
    ((0.0, 0.0, -1.0), (-1.0, 0.0, 0.0), N),
    (E, (0.0, 0.0, -1.0), N),
)


def eight_position(
    minutes: float = 10.0, dt_s: float = 1.0, kind: str = "sdf-gyro", latitude_deg=DEFAULT_LATITUDE
) -> Plan:
    """Hu's eight-position torque-feedback test (Hu 3-1 to 3-11), one record per position.

    For a TDF gyro the (x, y, z) of each position are its X, Y and spin axes; for an SDF gyro they are
    (IA, OA, SA). Each position is a separate mounting on a fixture (one dummy axis, Up, held at zero).
    """
    runs = []
    for i, (x, y, _z) in enumerate(HU_EIGHT_POSITIONS, start=1):
        mount = tdf_mount(x, y) if kind == "tdf-gyro" else sdf_mount(x, y)
        runs.append(Run(f"pos{i}", (("fixture", U),), mount, (Segment((0.0,), minutes * 60.0, dt_s),)))
    return Plan(
        "eight-position", tuple(runs), latitude_deg, description="Hu's eight-position test", reference="Hu 3-1 to 3-11"
    )


MULTIPOSITION_SETS = {
    6: [(0, 0), (90, 0), (180, 0), (270, 0), (90, 90), (90, 270)],
    8: [(t, p) for t in (0, 90, 180, 270) for p in (0, 90)],
    16: [(t, p) for t in range(0, 360, 45) for p in (0, 90)],
    24: [(t, p) for t in range(0, 360, 45) for p in (0, 120, 240)],
    30: [(t, p) for t in range(0, 360, 60) for p in range(0, 360, 72)],
}
"""Equal-interval position sets on the two-axis table (trunnion, platform) in deg.

The 16- and 30-position sets follow the counts Liu & Fan (1983) found optimal for the simplified and the full
DTG error equation; their exact angles are not in our sources, so these are equal-interval sets of that size.
"""


def multiposition(
    n: int = 24,
    minutes: float = 10.0,
    dt_s: float = 1.0,
    mount: dict | None = None,
    latitude_deg=DEFAULT_LATITUDE,
    positions=None,
) -> Plan:
    """Static multi-position test on a two-axis table (outer trunnion East, inner normal to the platform).

    ``positions`` overrides the built-in set: a list of (trunnion, platform) angles in deg.
    """
    if positions is None:
        if n not in MULTIPOSITION_SETS:
            raise PlanError(f"no built-in {n}-position set; built-in: {sorted(MULTIPOSITION_SETS)}")
        positions = MULTIPOSITION_SETS[n]
    segs = tuple(Segment((float(a), float(b)), minutes * 60.0, dt_s, label=i) for i, (a, b) in enumerate(positions))
    run = Run(f"{len(positions)}pos", TWO_AXIS, mount or SKEW_MOUNT, segs)
    return Plan(
        f"multiposition-{len(positions)}",
        (run,),
        latitude_deg,
        description=f"{len(positions)}-position static test on a two-axis table",
        reference="Hu 3-1 to 3-11 (principle); Liu & Fan 1983 (position counts)",
    )


def tumble(
    revolutions: float = 2.0,
    earth_rates: float = 10.0,
    dt_s: float = 2.0,
    flip: bool = True,
    both_directions: bool = True,
    indexed_positions: int | None = None,
    dwell_s: float = 300.0,
    latitude_deg=DEFAULT_LATITUDE,
) -> Plan:
    """Single-axis polar tumble test (Hu 3-12 to 3-21).

    The table axis is polar, so the Earth rate on the IA (normal to the axis) is constant; the OA lies along
    the table axis and IA, SA turn through g. ``flip`` adds the mounting turned 180° about IA (OA and SA
    reversed); ``both_directions`` adds CW runs to the CCW ones. ``indexed_positions`` replaces the continuous
    turn by that many static positions of ``dwell_s`` each.
    """
    axis = polar_axis(latitude_deg)
    rate = earth_rates * units.OMEGA_IE_DEG_PER_H / 3600.0  # deg/s
    runs = []
    for direction, sign in (("ccw", 1.0), ("cw", -1.0))[: 2 if both_directions else 1]:
        for mname, oa in (("up", axis), ("flip", tuple(-c for c in axis)))[: 2 if flip else 1]:
            mount = sdf_mount(E, oa)
            if indexed_positions:
                segs = tuple(
                    Segment((sign * 360.0 * j / indexed_positions,), dwell_s, dt_s, label=j)
                    for j in range(indexed_positions)
                )
            else:
                dur = revolutions * 360.0 / rate
                segs = (Segment((0.0,), dur, dt_s, rate_dps=(sign * rate,)),)
            runs.append(Run(f"{direction}-{mname}", (("polar", axis),), mount, segs))
    return Plan(
        "tumble",
        tuple(runs),
        latitude_deg,
        description="polar single-axis tumble, flipped, CW/CCW",
        reference="Hu 3-12 to 3-21",
    )


def two_axis_tumble(
    m: int = 5,
    n: int = 1,
    earth_rates: float = 10.0,
    revolutions: float = 1.0,
    dt_s: float = 2.0,
    latitude_deg=DEFAULT_LATITUDE,
) -> Plan:
    """Two-axis tumble with rate ratio m:n (Hu 3-47 to 3-53, fig. 3-22).

    The outer axis is polar and carries the OA; the inner axis lies in the meridian at (0, −sin φ, cos φ) and
    carries the IA, so the IA sees only the inner-axis rate. The outer axis turns at m·r and the inner at n·r
    (r = ``earth_rates`` Earth rates); ``revolutions`` counts revolutions of the slower axis. Ratios whose
    harmonics collide (such as 1:2) are allowed here but defeat Hu's harmonic separation (3-51).
    """
    axis = polar_axis(latitude_deg)
    p = math.radians(latitude_deg)
    inner = (0.0, -math.sin(p), math.cos(p))
    r = earth_rates * units.OMEGA_IE_DEG_PER_H / 3600.0
    dur = revolutions * 360.0 / (r * min(m, n))
    seg = Segment((0.0, 0.0), dur, dt_s, rate_dps=(m * r, n * r))
    run = Run(f"tumble-{m}-{n}", (("outer", axis), ("inner", inner)), sdf_mount(inner, axis), (seg,))
    return Plan(
        f"two-axis-tumble-{m}:{n}",
        (run,),
        latitude_deg,
        description=f"two-axis tumble {m}:{n}",
        reference="Hu 3-47 to 3-53",
    )


def servo(orientation: str = "polar", hours: float = 24.0, dt_s: float = 1.0, latitude_deg=DEFAULT_LATITUDE) -> Plan:
    """Servo (table-following) test: the pickoff drives the table so the gyro stays at null (Hu 3-54 to 3-90).

    ``orientation``: ``"polar"`` (IA along the polar servo axis, Hu 3-86 and Tables 3-2/3-3: the table turns
    once a sidereal day less the drift), ``"vertical"`` (IA up, Hu 3-60), ``"horizontal"`` (IA north, Hu 3-74),
    the IA always along the servo axis. ``hours``: length of the record (h); ``dt_s``: sample interval (s);
    ``latitude_deg`` in deg.
    """
    geo = {
        "polar": (polar_axis(latitude_deg), E),
        "vertical": (U, E),
        "horizontal": (N, E),
    }
    if orientation not in geo:
        raise PlanError(f"servo orientation {orientation!r}; valid: {sorted(geo)}")
    axis, oa0 = geo[orientation]
    oa = np.cross(axis, np.cross(oa0, axis))  # component of oa0 normal to the axis
    mount = sdf_mount(axis, oa)
    run = Run(
        f"servo-{orientation}",
        (("servo", axis),),
        mount,
        (Segment((0.0,), hours * 3600.0, dt_s),),
        mode="servo",
        servo_axis="servo",
    )
    return Plan(
        f"servo-{orientation}",
        (run,),
        latitude_deg,
        description=f"{orientation} servo test",
        reference="Hu 3-54 to 3-90, Tables 3-2/3-3",
    )


def polar_servo_north_south(hours: float = 12.0, dt_s: float = 10.0, latitude_deg=DEFAULT_LATITUDE) -> Plan:
    """Hu's polar servo test in its two mountings: the servo axis along the Earth's axis, the IA along it (north)
    and against it (south), ``hours`` each (h), read every ``dt_s`` (s), at ``latitude_deg`` (deg) (Hu 3-86..3-90:
    the two mountings separate the IA terms of even and odd order)."""
    ax = np.array(polar_axis(latitude_deg))
    runs = []
    for name, sign in (("north", 1.0), ("south", -1.0)):
        ia = sign * ax
        oa = np.array([1.0, 0.0, 0.0]) - ia[0] * ia  # East, made normal to the IA
        seg = (Segment((0.0,), hours * 3600.0, dt_s),)
        runs.append(
            Run(f"polar-{name}", (("servo", tuple(ax)),), sdf_mount(ia, oa), seg, mode="servo", servo_axis="servo")
        )
    return Plan(
        "polar-north-south",
        tuple(runs),
        latitude_deg,
        description="polar servo test, north and south mountings",
        reference="Hu 3-86 to 3-90",
    )


def rate_ladder(
    rates_dps=(1, 2, 5, 10, 20, 50, 100),
    seconds: float = 60.0,
    dt_s: float = 0.1,
    mountings=("axial", "O", "S"),
    latitude_deg=DEFAULT_LATITUDE,
    scale_factor=3600.0,
) -> Plan:
    """Rate transfer test: ± rates about Up (Titterton §8.5.2; Hu ch. 3 appendix 1 for the torquer).

    Mountings: ``axial`` (IA up), ``O`` (IA tilted 45° toward OA), ``S`` (IA tilted 45° toward SA); together they
    separate scale-factor error from IA misalignment. ``rates_dps`` in deg/s, each held ``seconds`` (s) in both
    directions, sampled every ``dt_s`` (s); ``scale_factor`` S_nom in deg/h/mA.
    """
    s = 1.0 / math.sqrt(2.0)
    mounts = {
        "axial": sdf_mount(U, N),
        "O": sdf_mount((-s, 0.0, s), (s, 0.0, s)),
        "S": sdf_mount((0.0, s, s), (1.0, 0.0, 0.0)),
    }
    ladder = [sgn * float(r) for r in rates_dps for sgn in (1.0, -1.0)]
    runs = []
    for m in mountings:
        if m not in mounts:
            raise PlanError(f"rate-ladder mounting {m!r}; valid: {sorted(mounts)}")
        segs = tuple(Segment((0.0,), seconds, dt_s, rate_dps=(r,), label=i) for i, r in enumerate(ladder))
        runs.append(Run(f"ladder-{m}", (("rate", U),), mounts[m], segs, scale_factor=scale_factor))
    return Plan(
        "rate-ladder",
        tuple(runs),
        latitude_deg,
        description="rate ladder, three mountings",
        reference="Titterton §8.5.2; Hu ch. 3 appendix 1",
    )


def tdf_tumble(
    revolutions: float = 2.0, earth_rates: float = 10.0, dt_s: float = 2.0, latitude_deg=DEFAULT_LATITUDE
) -> Plan:
    """TDF gyro tumble about a polar axis, spin axis along and then against the axis (Hu 3-22 to 3-37).

    The table turns at ``earth_rates`` times Earth rate (dimensionless multiple of 15.04 deg/h) for
    ``revolutions`` turns, sampled every ``dt_s`` (s); ``latitude_deg`` in deg.
    """
    axis = polar_axis(latitude_deg)
    rate = earth_rates * units.OMEGA_IE_DEG_PER_H / 3600.0
    dur = revolutions * 360.0 / rate
    runs = []
    for name, z in (("up", axis), ("flip", tuple(-c for c in axis))):
        x = E
        y = tuple(np.cross(z, x))
        runs.append(
            Run(f"tdf-{name}", (("polar", axis),), tdf_mount(x, y), (Segment((0.0,), dur, dt_s, rate_dps=(rate,)),))
        )
    return Plan("tdf-tumble", tuple(runs), latitude_deg, description="TDF polar tumble", reference="Hu 3-22 to 3-37")


def accel_tumble(
    positions: int = 36,
    dwell_s: float = 60.0,
    dt_s: float = 1.0,
    latitude_deg=DEFAULT_LATITUDE,
    head_along: str = "oa",
) -> Plan:
    """Accelerometer dividing-head tumble: IA turned through g in the vertical plane about a horizontal head axis
    (North), ``positions`` equally spaced positions of ``dwell_s`` s, sampled every ``dt_s`` s (Hu 3-38 to 3-46).

    ``head_along`` names the instrument axis along the head axis, Hu's two test states: ``"oa"`` (a_O = 0, PA turns
    with IA: the a_I·a_P term shows at 2θ, Hu 3-43) or ``"pa"`` (a_P = 0, OA turns with IA: the a_I·a_O term, Hu
    3-42); K_0, K_1, K_2, K_3 show in both (Hu 3-46)."""
    mounts = {"oa": accel_mount(U, E), "pa": accel_mount(U, N)}
    if head_along not in mounts:
        raise PlanError(f"accel-tumble head_along {head_along!r}; valid: {sorted(mounts)}")
    segs = tuple(Segment((360.0 * j / positions,), dwell_s, dt_s, label=j) for j in range(positions))
    name = "accel-tumble" if head_along == "oa" else "accel-tumble-pa"
    run = Run(name, (("head", N),), mounts[head_along], segs, scale_factor=1e-3)
    return Plan(name, (run,), latitude_deg, description="accelerometer tumble", reference="Hu 3-38 to 3-46")


BUILDERS = {
    "fixed": (fixed_position, "fixed-position drift test (Hu ch. 3 §2)"),
    "eight-position": (eight_position, "Hu's eight-position torque-feedback test (Hu 3-1 to 3-11)"),
    "multiposition": (multiposition, "6/8/16/24/30-position static test on a two-axis table"),
    "tumble": (tumble, "polar single-axis tumble, flipped mounting, CW and CCW (Hu 3-12 to 3-21)"),
    "two-axis-tumble": (two_axis_tumble, "two-axis tumble at rate ratio m:n (Hu 3-47 to 3-53)"),
    "servo": (servo, "servo test: polar, vertical or horizontal IA (Hu 3-54 to 3-90)"),
    "rate-ladder": (rate_ladder, "± rate ladder in three mountings (Titterton §8.5.2)"),
    "tdf-tumble": (tdf_tumble, "two-degree-of-freedom gyro polar tumble (Hu 3-22 to 3-37)"),
    "accel-tumble": (accel_tumble, "pendulous accelerometer tumble (Hu 3-38 to 3-46)"),
}


MAX_SAMPLES = 50_000_000
"""A plan asking for more samples than this (all runs together) is refused rather than simulated."""


def build(name: str, **options) -> Plan:
    """Build a built-in plan by name with keyword options (see ``gyrojax plans``); the result is validated."""
    if name not in BUILDERS:
        raise PlanError(f"unknown plan {name!r}; built-in plans: {', '.join(BUILDERS)}")
    try:
        plan = BUILDERS[name][0](**options)
    except (TypeError, ValueError, ZeroDivisionError, OverflowError) as e:
        if isinstance(e, PlanError):
            raise
        raise PlanError(f"plan {name!r}: bad option(s) {options}: {e}") from None
    return validate_plan(plan, f"plan {name!r} with options {options}")


# ---- validation ------------------------------------------------------------------------------------------------


def validate_plan(plan: Plan, where: str = "plan") -> Plan:
    """Check a plan's numbers and each run's geometry (as the record it will become); errors name the key."""
    if not is_finite_number(plan.latitude_deg) or not -90.0 <= plan.latitude_deg <= 90.0:
        raise PlanError(f"{where}: key 'latitude_deg' must be a number in [-90, 90], got {plan.latitude_deg!r}")
    g = plan.gravity_mps2
    if g is not None and (not is_finite_number(g) or not 9.7 <= g <= 9.9):
        raise PlanError(
            f"{where}: key 'gravity_mps2' must be null or a number in [9.7, 9.9], got {plan.gravity_mps2!r}"
        )
    if not plan.runs:
        raise PlanError(f"{where}: key 'runs' must hold at least one run")
    total = 0
    for i, run in enumerate(plan.runs):
        k = len(run.axes)
        if not run.segments:
            raise PlanError(f"{where}: key 'runs[{i}].segments' must hold at least one segment")
        for j, seg in enumerate(run.segments):
            at = f"runs[{i}].segments[{j}]"
            for key in ("start_deg", "rate_dps", "amplitude_deg"):
                v = getattr(seg, key)
                if v is None and key != "start_deg":
                    continue
                if not isinstance(v, (list, tuple)) or len(v) != k or not all(is_finite_number(x) for x in v):
                    raise PlanError(
                        f"{where}: key '{at}.{key}' needs {k} value(s), finite numbers (one per table axis), got {v!r}"
                    )
            for key in ("duration_s", "dt_s"):
                v = getattr(seg, key)
                if not is_finite_number(v) or not v > 0:
                    raise PlanError(f"{where}: key '{at}.{key}' must be a finite number > 0, got {v!r}")
            if not is_finite_number(seg.frequency_hz):
                raise PlanError(f"{where}: key '{at}.frequency_hz' must be a finite number, got {seg.frequency_hz!r}")
            total += max(1, round(seg.duration_s / seg.dt_s))
            if total > MAX_SAMPLES:
                raise PlanError(
                    f"{where}: key '{at}' asks for {seg.duration_s / seg.dt_s:.3g} samples; a plan may "
                    f"have at most {MAX_SAMPLES:.0e} samples in all (shorten duration_s or raise dt_s)"
                )
        if not is_finite_number(run.gap_s) or run.gap_s < 0:
            raise PlanError(f"{where}: key 'runs[{i}].gap_s' must be a finite number >= 0, got {run.gap_s!r}")
        inst = run.instrument if isinstance(run.instrument, dict) else {}
        sf_key = "scale_factor_g_per_mA" if inst.get("kind") == "pendulous-accel" else "scale_factor_deg_per_h_per_mA"
        meta = {
            "format": FORMAT,
            "name": run.name,
            "site": {"latitude_deg": plan.latitude_deg, "gravity_mps2": plan.gravity_mps2 or units.G0},
            "table": {"axes": [{"name": n, "axis_enu": list(u)} for n, u in run.axes]},
            "instrument": run.instrument,
            "mode": run.mode,
            sf_key: run.scale_factor,
            "servo_axis": run.servo_axis,
        }
        try:
            validate_meta(meta, f"runs[{i}]")
        except RecordError as e:
            msg = str(e).replace("'scale_factor_deg_per_h_per_mA'", "'scale_factor'")
            raise PlanError(f"{where}: {msg.replace('scale_factor_g_per_mA', 'scale_factor')}") from None
    return plan


def with_dt(plan: Plan, dt_s: float) -> Plan:
    """The same plan sampled at ``dt_s``."""
    runs = tuple(replace(r, segments=tuple(replace(s, dt_s=dt_s) for s in r.segments)) for r in plan.runs)
    return replace(plan, runs=runs)
