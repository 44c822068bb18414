"""The classical closed-form analyses of Hu ch. 3, as independent cross-checks of the general fit.

Every function here is a pure numpy function of arrays; none of them calls the project's measurement model.
They reproduce the book's procedures (harmonic analysis of a tumble or a servo run, the eight-position closed form,
the torquer scale-factor table) with the book's misprints corrected; each docstring names the equations it
implements and the corrections made. Outputs use the conventions' names and signs (reaction-up specific force, so
``D_x(book) = −D_I``, ``D_y(book) = −D_O``, ``D_z(book) = −D_S``, squared and product terms unchanged).

Units: rates and drifts in deg/h, angles in rad, latitude in deg, ``g`` is the site gravity in units of
g0 (= g_site/9.80665, so that the specific force along an axis is ``g·cos(angle)`` in g).

Harmonic convention: a series in an angle θ is written ``A_0 + Σ_k (A_k cos kθ + B_k sin kθ)`` and returned as a
dict ``{"A0": …, "A1": …, "B1": …}``; θ is the record's table angle (right-handed about the table axis,
conventions §3).
"""

from __future__ import annotations

import numpy as np

from gyrojax import units

OMEGA_E = units.OMEGA_IE_DEG_PER_H  # Earth rate, deg/h

# ---- harmonic analysis (Hu 4-12 to 4-22) ---------------------------------------------------------------------


def fourier_design(angle_rad, freqs):
    """Columns [1, cos f₁θ, sin f₁θ, cos f₂θ, sin f₂θ, …] for the (signed, non-zero) frequencies ``freqs`` (Hu 4-12).

    θ = ``angle_rad`` in rad; ``freqs`` are harmonic orders in cycles per revolution (dimensionless).
    """
    th = np.asarray(angle_rad, dtype=float)
    cols = [np.ones_like(th)]
    for f in freqs:
        cols += [np.cos(f * th), np.sin(f * th)]
    return np.stack(cols, axis=-1)


def harmonic_fit(angle_rad, y, freqs, weight=None, interval_mean=False):
    """Least-squares Fourier coefficients of ``y`` in the angle, at the given frequencies (Hu 4-12, 4-64 to 4-75).

    Returns the flat vector [A0, A(f₁), B(f₁), A(f₂), B(f₂), …]. With ``interval_mean=True`` the n−1 values of ``y``
    are means over the intervals between the n angles (a servo record's Δθ/Δt): each regressor is then the
    trapezoid ½[φ(θ_k) + φ(θ_{k+1})], exact to O(Δθ²). For equally spaced angles over whole revolutions this
    equals Hu's discrete sums (4-20 to 4-22); least squares also serves uneven coverage (a servo run that does
    not close its revolution).

    ``angle_rad`` in rad, ``freqs`` in cycles per revolution (dimensionless); coefficients in the same units as ``y``.
    """
    X = fourier_design(angle_rad, freqs)
    if interval_mean:
        X = 0.5 * (X[1:] + X[:-1])
    y = np.asarray(y, dtype=float)
    if weight is not None:
        w = np.sqrt(np.asarray(weight, dtype=float))
        X, y = X * w[:, None], y * w
    coef, *_ = np.linalg.lstsq(X, y, rcond=None)
    return coef


def _as_dict(coef, order):
    out = {"A0": float(coef[0])}
    for k in range(1, order + 1):
        out[f"A{k}"] = float(coef[2 * k - 1])
        out[f"B{k}"] = float(coef[2 * k])
    return out


def fourier_sums(y, order=2):
    """Hu's discrete Fourier estimators for n samples equally spaced over one revolution, θ_m = 2πm/n (Hu 4-20 to 4-22).

    a_0 = (1/n) Σ y_m;  a_r = (2/n) Σ y_m cos(2π r m/n),  b_r = (2/n) Σ y_m sin(2π r m/n)  (r < n/2);
    a_{n/2} = (1/n) Σ y_m cos mπ, b_{n/2} = 0. (The "−1/n" printed in 4-20 is an OCR artefact.)
    Samples over several whole revolutions may be passed as shape (cycles, n); the cycles are averaged.
    """
    y = np.atleast_2d(np.asarray(y, dtype=float)).mean(axis=0)
    n = y.shape[0]
    m = np.arange(n)
    out = {"A0": float(y.mean())}
    for r in range(1, order + 1):
        if 2 * r > n:
            raise ValueError(f"order {order} needs at least {2 * order} samples per revolution, got {n}")
        w = 1.0 if 2 * r == n else 2.0
        out[f"A{r}"] = float(w / n * np.sum(y * np.cos(2 * np.pi * r * m / n)))
        out[f"B{r}"] = 0.0 if 2 * r == n else float(2.0 / n * np.sum(y * np.sin(2 * np.pi * r * m / n)))
    return out


# ---- single-axis polar tumble (Hu 3-12 to 3-21) --------------------------------------------------------------


def tumble_harmonics(angle_rad, drift_deg_per_h, order=2, weight=None):
    """Harmonics {A0, A1, B1, …} of the drift in a tumble, by least squares in the table angle (Hu 3-14, 3-16).

    ``drift_deg_per_h`` is the indicated rate less the kinematic input (in the polar tumble the IA is normal to the
    table axis and to the Earth's axis, so the input is zero). ``angle_rad`` in rad; harmonics in deg/h.
    """
    return _as_dict(harmonic_fit(angle_rad, drift_deg_per_h, range(1, order + 1), weight), order)


def tumble_coefficients(
    normal: dict,
    flipped: dict,
    latitude_deg: float,
    g: float = 1.0,
    static_up: float | None = None,
    static_down: float | None = None,
) -> dict:
    """Drift coefficients from the harmonics of a polar tumble, normal and flipped (Hu 3-14, 3-16, 3-18, 3-20, 3-21).

    Geometry (``gyrojax.data.plans.tumble``, Hu fig. 3-10/3-11): table axis polar, OA along the axis (up) in the normal
    mounting and against it in the flipped one (turned 180° about IA), IA East at θ = 0. In the conventions' signs the
    specific force is a_I = −g cosφ sinθ, a_O = ±g sinφ, a_S = ±g cosφ cosθ (upper sign normal), so the drift is

        A0 = D_F ± D_O g sinφ + D_OO g² sin²φ + ½(D_II + D_SS) g² cos²φ
        A1 = ±D_S g cosφ + D_OS g² sinφ cosφ        B1 = −D_I g cosφ ∓ D_IO g² sinφ cosφ
        A2 = ½(D_SS − D_II) g² cos²φ                B2 = ∓½ D_IS g² cos²φ

    Hu's angle runs the other way (θ_book = −θ, so B_book = −B) and his D_x, D_y, D_z carry the opposite sign. With
    these, his separation (3-21), corrected, reads (book symbols → the conventions' names):

        D_x = −(B11 + B12)/2g cosφ → −D_I;  D_z = (A12 − A11)/2g cosφ → −D_S;  D_xy = (B11 − B12)/g² sin2φ → D_IO;
        D_xz = −2B22/g² cos²φ = (B21 − B22)/g² cos²φ → D_IS;  D_yz = (A11 + A12)/g² sin2φ → D_OS;
        with the static runs OA up/down (3-18, 3-20: i₃k = D_0 − D_y g, i₄k = D_0 + D_y g):
        D_0 = ½k(i₃ + i₄),  D_y = k(i₄ − i₃)/2g,
        D_xx = [A01 + A02 − A21 − A22 − k(i₃ + i₄)]/2g² cos²φ,  D_zz = [A01 + A02 + A21 + A22 − k(i₃ + i₄)]/2g² cos²φ.

    Misprints corrected (3-14, 3-16, the list after them, 3-21): A11, A12 carry D_z, not D_x; B21, B22 carry D_xz, not
    D_xx; the listed B11 carries D_xy (printed D_yz) and B12 is −D_x g cosφ − ½D_xy g² sin2φ (printed garbled);
    3-21 prints D_z with A21 for A11, the second D_xz for D_zz, D_xz = +2B22/… with the wrong sign, and D_y without k.

    Without static runs, D_O comes from the tumbles alone (A02 − A01 = 2D_y g sinφ) and D_F, D_II, D_SS are not
    separable (only D_SS − D_II and the constant ``A0_mean`` are returned). With static runs (indicated outputs
    S·i in deg/h with OA up and down, IA East), D_F, D_II, D_SS are returned; a non-zero D_OO then appears as
    D_F + D_OO g², D_II − D_OO, D_SS − D_OO (the 1-g alias of the squared terms).
    """
    phi = np.deg2rad(latitude_deg)
    c, s = np.cos(phi), np.sin(phi)
    s2, c2 = np.sin(2 * phi), c * c
    # the book's harmonics: its angle is −θ, so its B's are −B
    A01, A11, B11, A21, B21 = normal["A0"], normal["A1"], -normal["B1"], normal["A2"], -normal["B2"]
    A02, A12, B12, A22, B22 = flipped["A0"], flipped["A1"], -flipped["B1"], flipped["A2"], -flipped["B2"]
    Dx = -(B11 + B12) / (2 * g * c)
    Dz = (A12 - A11) / (2 * g * c)
    Dxy = (B11 - B12) / (g * g * s2)
    Dxz = (B21 - B22) / (g * g * c2)
    Dyz = (A11 + A12) / (g * g * s2)
    out = {
        "D_I": -Dx,
        "D_S": -Dz,
        "D_IO": Dxy,
        "D_IS": Dxz,
        "D_OS": Dyz,
        "D_SS-D_II": (A21 + A22) / (g * g * c2),
        "A0_mean": 0.5 * (A01 + A02),
    }
    if static_up is None or static_down is None:
        out["D_O"] = -(A02 - A01) / (2 * g * s)
        return {k: float(v) for k, v in out.items()}
    k_i3, k_i4 = static_up, static_down  # i₃k (OA up, book g_y = −g), i₄k (OA down)
    D0 = 0.5 * (k_i3 + k_i4)
    Dy = (k_i4 - k_i3) / (2 * g)
    Dxx = (A01 + A02 - A21 - A22 - (k_i3 + k_i4)) / (2 * g * g * c2)
    Dzz = (A01 + A02 + A21 + A22 - (k_i3 + k_i4)) / (2 * g * g * c2)
    out.update({"D_F": D0, "D_O": -Dy, "D_II": Dxx, "D_SS": Dzz})
    return {k: float(v) for k, v in out.items()}


# ---- eight-position test of a TDF gyro (Hu 3-1 to 3-11) -------------------------------------------------------


def eight_position_solution(I_x, I_y, latitude_deg: float) -> dict:
    """Hu's eight-position closed form for a TDF gyro (Hu 3-10, 3-11, corrected).

    ``I_x``, ``I_y``: the torquer currents (mA, positive for positive precession) of positions 1–8
    (``gyrojax.data.plans.HU_EIGHT_POSITIONS``). Hu's x torquer precesses the rotor about y, so I_x·k_x reads the rate
    about y and I_y·k_y the rate about x. The position equations, as 3-11 uses them (with the physics: R and u
    are fixed in the case, only the Earth term and the g direction change):

        I_x k_x = −R_x + ω_y + (u_y at 1–4; −u_zx·(y·up) at 6, 8)
        I_y k_y =  R_y + ω_x + (u_x at 1–4; −u_xy·(x·up) at 5, 7)

    Solution (3-10, 3-11): k_x = 2Ω cosφ/(I_x1 − I_x3), k_y = 2Ω cosφ/(I_y2 − I_y4);
    R_x = −mean(I_x5, I_x7)·k_x, R_y = mean(I_y6, I_y8)·k_y;
    u_zx = mean(Ω sinφ − R_x − I_x6 k_x,  Ω sinφ + R_x + I_x8 k_x);
    u_xy = mean(Ω sinφ + R_y − I_y5 k_y,  Ω sinφ − R_y + I_y7 k_y);
    u_x = mean(I_y1 k_y − R_y, I_y2 k_y − R_y − Ω cosφ, I_y3 k_y − R_y, I_y4 k_y − R_y + Ω cosφ);
    u_y = mean(I_x1 k_x + R_x − Ω cosφ, I_x2 k_x + R_x, I_x3 k_x + R_x + Ω cosφ, I_x4 k_x + R_x).

    Misprints corrected: in 3-11 the u_zx lines print I_x8 for I_x6 and I_x3 for I_x8, and the first u_xy line
    prints I_y6 for I_y5; the y-lines of 3-4, 3-5, 3-8, 3-9 carry a spurious leading minus (they contradict 3-10,
    3-11 and a case-fixed R_y), and 3-8 prints u_zy for u_xy.
    """
    Ix = np.asarray(I_x, dtype=float)
    Iy = np.asarray(I_y, dtype=float)
    if Ix.shape != (8,) or Iy.shape != (8,):
        raise ValueError("I_x and I_y need the 8 position currents each")
    phi = np.deg2rad(latitude_deg)
    wc, ws = OMEGA_E * np.cos(phi), OMEGA_E * np.sin(phi)
    x = dict(zip(range(1, 9), Ix, strict=True))
    y = dict(zip(range(1, 9), Iy, strict=True))
    kx = 2 * wc / (x[1] - x[3])
    ky = 2 * wc / (y[2] - y[4])
    Rx = -0.5 * (x[5] + x[7]) * kx
    Ry = 0.5 * (y[6] + y[8]) * ky
    uzx = 0.5 * ((ws - Rx - x[6] * kx) + (ws + Rx + x[8] * kx))
    uxy = 0.5 * ((ws + Ry - y[5] * ky) + (ws - Ry + y[7] * ky))
    ux = np.mean([y[1] * ky - Ry, y[2] * ky - Ry - wc, y[3] * ky - Ry, y[4] * ky - Ry + wc])
    uy = np.mean([x[1] * kx + Rx - wc, x[2] * kx + Rx, x[3] * kx + Rx + wc, x[4] * kx + Rx])
    return {k: float(v) for k, v in dict(k_x=kx, k_y=ky, R_x=Rx, R_y=Ry, u_x=ux, u_y=uy, u_zx=uzx, u_xy=uxy).items()}


def eight_position_to_tdf(sol: dict, g: float = 1.0) -> dict:
    """Hu's eight-position quantities in conventions §4 TDF names (derivation in :func:`eight_position_solution`).

    Our channel X reads ω_X, i.e. Hu's y torquer; channel Y is Hu's x torquer. Hu's u's are drifts at the site's
    full gravity, ours are per g0, hence (``g`` = g_site/g0):
    DX_F = R_y, DY_F = −R_x, DX_Z = u_x/g, DY_Z = u_y/g, DX_X = −u_xy/g, DY_Y = −u_zx/g; k_y and k_x are the actual
    scale factors of channels X and Y (deg/h/mA).
    """
    return {
        "DX_F": sol["R_y"],
        "DY_F": -sol["R_x"],
        "DX_Z": sol["u_x"] / g,
        "DY_Z": sol["u_y"] / g,
        "DX_X": -sol["u_xy"] / g,
        "DY_Y": -sol["u_zx"] / g,
        "k_X": sol["k_y"],
        "k_Y": sol["k_x"],
    }


def mean_and_sigma(rows):
    """Column means and sample standard deviations (n − 1), as in Hu Table 3-1's last two rows."""
    a = np.asarray(rows, dtype=float)
    return a.mean(axis=0), a.std(axis=0, ddof=1)


# ---- polar servo test (Hu 3-59, 3-84 to 3-90, Tables 3-2, 3-3) -----------------------------------------------


def servo_harmonics(angle_rad, time_s, order=2, weight=None, exact=True):
    """Harmonics {A0, A1, B1, …} of the servo-table rate θ̇(θ) (deg/h) in its own angle (Hu 3-88, 4-12 to 4-22).

    A servo record gives the angle θ_k at times t_k; the measurement is the mean rate Δθ/Δt over each interval
    (Hu 3-91 and ch. 4 §1). ``weight`` (0/1 per interval, length n−1) masks intervals across segments.

    First a linear least-squares fit of Δθ/Δt on the interval means of the basis (trapezoid, exact to O(Δθ²)).
    With ``exact`` the fit is refined by Gauss–Newton on the intervals' durations, Δt_k = ∫ dθ/θ̇(θ) over
    [θ_k, θ_{k+1}] (4-point Gauss–Legendre), which is exact for a rate that is a trigonometric polynomial in θ.
    Note that Hu 3-88 names the sine terms A and the cosine terms B; here A is always the cosine.
    """
    th = np.asarray(angle_rad, dtype=float)
    t = np.asarray(time_s, dtype=float) / units.SECONDS_PER_HOUR
    dth, dt = np.diff(th), np.diff(t)
    w = np.ones_like(dt) if weight is None else np.asarray(weight, dtype=float)
    freqs = range(1, order + 1)
    coef = harmonic_fit(th, dth / np.where(dt > 0, dt, 1.0) / units.DEG, freqs, w, interval_mean=True)
    if exact:
        xg, wg = np.polynomial.legendre.leggauss(4)
        nodes = 0.5 * (th[:-1, None] + th[1:, None]) + 0.5 * dth[:, None] * xg  # (n−1, 4)
        Xq = fourier_design(nodes, freqs)  # (n−1, 4, p)
        sw = np.sqrt(w)
        for _ in range(4):
            rate = (Xq @ coef) * units.DEG  # rad/h at the nodes
            dur = 0.5 * dth * np.sum(wg / rate, axis=1)
            J = -0.5 * dth[:, None] * np.einsum("q,kq,kqp->kp", wg, units.DEG / rate**2, Xq)
            step, *_ = np.linalg.lstsq(J * sw[:, None], (dt - dur) * sw, rcond=None)
            coef = coef + step
    return _as_dict(coef, order)


def servo_coefficients(north: dict, south: dict, latitude_deg: float, g: float = 1.0) -> dict:
    """Drift coefficients from the table-rate harmonics of two polar servo runs, IA north and IA south (Hu Table 3-3).

    Geometry: the servo axis is the IA; "north" is ``plans.servo("polar")`` (axis and IA (0, cosφ, sinφ), OA East at
    θ = 0), "south" the same with axis and IA reversed (OA East at θ = 0). Then a_I = ±g sinφ, a_O = ∓g cosφ sinθ,
    a_S = ∓g cosφ cosθ, and the table turns at θ̇ = ∓Ω − drift (Hu 3-59), so

        A0 = ∓Ω − [D_F ± D_I g sinφ + D_II g² sin²φ + ½(D_OO + D_SS) g² cos²φ]
        A1 = ±D_S g cosφ + D_IS g² sinφ cosφ      B1 = ±D_O g cosφ + D_IO g² sinφ cosφ
        A2 = −½(D_SS − D_OO) g² cos²φ             B2 = −½ D_OS g² cos²φ

    (upper sign north). Hu's figures start with OA West, i.e. θ_book = θ + π: his first harmonics have the other
    sign. Returned: D_I, D_S, D_O, D_IS, D_IO, D_OS, D_SS−D_OO and the constant C = D_F + D_II g² sin²φ +
    ½(D_OO + D_SS) g² cos²φ; D_F alone needs another run (Table 3-3 note 3).

    Relation to Table 3-3 (book symbols, its θ): U_x = (B1S − B1N)/2cosφ is our D_S and U_z = (A0N − A0S + 2Ω)/2sinφ
    is our −D_I (both right, with g = 1); K_zy = (A1N − A1S)/sin2φ is wrong (the sin θ g²-terms are equal in both
    runs, so this difference holds only D_O, which 3-59 leaves out: the sum −(A1N + A1S)/sin2φ gives D_IO), and
    K_xy = 2A2S/cos²φ "or −2A2N/cos²φ" has opposite signs for equal harmonics.
    """
    phi = np.deg2rad(latitude_deg)
    c, s = np.cos(phi), np.sin(phi)
    gc, gs, g2sc, g2c2 = g * c, g * s, g * g * s * c, g * g * c * c
    out = {
        "D_I": (south["A0"] - north["A0"] - 2 * OMEGA_E) / (2 * gs),
        "C": -0.5 * (north["A0"] + south["A0"]),
        "D_S": (north["A1"] - south["A1"]) / (2 * gc),
        "D_IS": (north["A1"] + south["A1"]) / (2 * g2sc),
        "D_O": (north["B1"] - south["B1"]) / (2 * gc),
        "D_IO": (north["B1"] + south["B1"]) / (2 * g2sc),
        "D_OS": -(north["B2"] + south["B2"]) / g2c2,
        "D_SS-D_OO": -(north["A2"] + south["A2"]) / g2c2,
    }
    return {k: float(v) for k, v in out.items()}


# ---- two-axis tumble (Hu 3-47 to 3-53) -------------------------------------------------------------------------


def two_axis_frequencies(m: int, n: int) -> tuple[int, ...]:
    """The 12 signed frequencies of Hu 3-51, in his order.

    m−2n, m−n, n, 2(m−n), m, 2n, 2m−n, m+n, 2m, m+2n, 2m+n, 2(m+n).
    """
    return (m - 2 * n, m - n, n, 2 * (m - n), m, 2 * n, 2 * m - n, m + n, 2 * m, m + 2 * n, 2 * m + n, 2 * (m + n))


def two_axis_harmonics(theta_rad, drift_deg_per_h, m: int, n: int, weight=None) -> dict:
    """Coefficients A0, A1…A12, B1…B12 of Hu 3-51 by least squares (θ: the outer angle is mθ, the inner nθ).

    The 12 |frequencies| must be distinct and non-zero (e.g. m:n = 5:1 or 7:2), else the series aliases.
    """
    f = two_axis_frequencies(m, n)
    if len({abs(x) for x in f}) != 12 or 0 in f:
        raise ValueError(f"m:n = {m}:{n} makes frequencies of 3-51 coincide or vanish: {f}")
    coef = harmonic_fit(theta_rad, drift_deg_per_h, f, weight)
    out = {"A0": float(coef[0])}
    for i in range(12):
        out[f"A{i + 1}"] = float(coef[1 + 2 * i])
        out[f"B{i + 1}"] = float(coef[2 + 2 * i])
    return out


def two_axis_coefficients(h: dict, latitude_deg: float, g: float = 1.0, book_signs: bool = False) -> dict:
    """Drift coefficients from the two-axis tumble harmonics (Hu 3-53, corrected).

    Geometry (Hu fig. 3-22, 3-47, 3-48): outer axis polar = OA at θ = 0, inner axis = IA ⟂ the Earth's axis in the
    meridian (book g_x0 = −g cosφ), SA West; outer angle mθ, inner nθ, both right-handed. In book symbols (gravity
    components, D_yy dropped as an alias of D_0, D_xx, D_zz):

        D_0 = A0 − A9 + 3(A4 + A12) + A6            D_x = −A5/g cosφ
        D_y = [(A8 − A2)/cosφ − A3/sinφ]/2g         D_z = [B3/sinφ − (B2 + B8)/cosφ]/2g
        D_xx = 2(A9 − A4 − A12)/g² cos²φ            D_zz = [(A10 − A1)/sin2φ − 2(A4 + A12)/cos²φ]/g²
        D_xy = [(A2 + A8)/sin2φ + (A7 − A11)/cos²φ]/g²   D_xz = 2(B7 + B11)/g² cos²φ
        D_yz = (4/3g²)[(B1 + B10)/sin2φ + (B4 − B12)/cos²φ]

    Misprints corrected in 3-53: D_0 prints +A9 and −A6; D_z prints −[B8/sinφ − (B2 + B4)/cosφ]/2g; the second
    D_xx is D_zz and prints A12 for A1. (3-50 and 3-52 misprints: see tests/test_classical.py.)
    Returned in the conventions' names (D_I = −D_x, D_O = −D_y, D_S = −D_z), or book symbols with ``book_signs``.
    """
    phi = np.deg2rad(latitude_deg)
    c, s = np.cos(phi), np.sin(phi)
    s2, c2, g2 = np.sin(2 * phi), c * c, g * g
    A = lambda i: h[f"A{i}"]  # noqa: E731
    B = lambda i: h[f"B{i}"]  # noqa: E731
    book = {
        "D_0": A(0) - A(9) + 3 * (A(4) + A(12)) + A(6),
        "D_x": -A(5) / (g * c),
        "D_y": ((A(8) - A(2)) / c - A(3) / s) / (2 * g),
        "D_z": (B(3) / s - (B(2) + B(8)) / c) / (2 * g),
        "D_xx": 2 * (A(9) - A(4) - A(12)) / (g2 * c2),
        "D_zz": ((A(10) - A(1)) / s2 - 2 * (A(4) + A(12)) / c2) / g2,
        "D_xy": ((A(2) + A(8)) / s2 + (A(7) - A(11)) / c2) / g2,
        "D_xz": 2 * (B(7) + B(11)) / (g2 * c2),
        "D_yz": 4.0 / (3.0 * g2) * ((B(1) + B(10)) / s2 + (B(4) - B(12)) / c2),
    }
    book = {k: float(v) for k, v in book.items()}
    if book_signs:
        return book
    return {
        "D_F": book["D_0"],
        "D_I": -book["D_x"],
        "D_O": -book["D_y"],
        "D_S": -book["D_z"],
        "D_II": book["D_xx"],
        "D_SS": book["D_zz"],
        "D_IO": book["D_xy"],
        "D_IS": book["D_xz"],
        "D_OS": book["D_yz"],
    }


# ---- torquer scale factor (Hu ch. 3 appendix 1) ----------------------------------------------------------------


def torquer_scale_factor(omega_deg_per_h, current_mA):
    """Scale factor of one servo-method measurement, K = −ω_y/i_y (Hu 附 3-5), deg/h/mA.

    ω_y = (θ̇_y1 + θ̇_y2)/2 is the half-sum of the table rates with +i_y and −i_y (the gyro's own drift cancels).
    """
    return -np.asarray(omega_deg_per_h, dtype=float) / np.asarray(current_mA, dtype=float)


def torquer_linearity(K_n, mean_decimals: int | None = None):
    """Mean scale factor K and linearity (K_n − K)/K × 100 % of each measurement (Hu 附 3-6).

    ``mean_decimals`` rounds K before the linearity is formed, as the book does (its table uses K = 17.171, the
    mean 17.1706 rounded to the data's three decimals). Returns (K, linearity_percent array).
    """
    k = np.asarray(K_n, dtype=float)
    K = k.mean()
    if mean_decimals is not None:
        K = np.round(K, mean_decimals)
    return float(K), (k - K) / K * 100.0
