"""The SDF gyro's *physical* model: mass unbalance, compliance tensor and angular momentum → drift coefficients.

The designer's view (Hu 2-12 to 2-28): a float of mass m whose centre of mass sits at l from the support centre
feels, in a specific-force field SF, the torque l × m·SF (Hu 2-12); under load the float structure deflects by
δ = q·m·SF with the compliance tensor q (Hu 2-16, 2-17), adding δ × m·SF (Hu 2-14). About the output axis (Hu 2-24,
axes x = IA, y = OA, z = SA)

    M_O = M_F0 − m l_I SF_S + m l_S SF_I + m²[K_SO SF_I SF_O − K_IO SF_O SF_S + (K_SS − K_II) SF_I SF_S
                                               + K_SI SF_I² − K_IS SF_S²]

and the drift about the input axis is ω_d = −M_O/H (Hu 2-27 for the channel whose torquer is on the output axis).
Hu's SF is the gravity vector (toward the ground), SF = −g0·a with a the specific force in g of conventions §4, so
the test engineer's view (conventions §6 names) is

    D_F = −M_F0/H,   D_I = m g0 l_S/H,   D_S = −m g0 l_I/H,
    D_II = −c K_SI,  D_SS = c K_IS,  D_IS = −c (K_SS − K_II),  D_IO = −c K_SO,  D_OS = c K_IO,   c = m² g0²/H,

and D_O = D_OO = 0: they have no simple physical cause (Hu 2-45 adds them to the mathematical model).
With a symmetric compliance tensor D_II = −D_SS. Units are CGS, as in the gyro literature: H in g·cm²/s, m in g,
l in cm, q in cm/dyn, M_F0 in dyn·cm; drift coefficients come out in deg/h per g^k.

The map back (:func:`physical_from_drift`) is not unique: l_O and K_OO, K_OI, K_OS, and K_II and K_SS apart from
their difference do not produce drift; they are set to zero.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from gyrojax import units

G0_CGS = units.G0 * 100.0  # cm/s²
AXES = "IOS"


@dataclass(frozen=True)
class PhysicalSDF:
    """Physical parameters of a floated SDF gyro (CGS units; axes I, O, S)."""

    H: float  # angular momentum, g·cm²/s
    m: float  # float mass, g
    l: tuple = (0.0, 0.0, 0.0)  # noqa: E741 (Hu's symbol) centre-of-mass offset (l_I, l_O, l_S), cm
    q: tuple = field(default_factory=lambda: ((0.0,) * 3,) * 3)  # compliance tensor K'_ij, cm/dyn (rows I, O, S)
    M_F0: float = 0.0  # acceleration-insensitive torque about OA, dyn·cm

    def torque(self, a) -> np.ndarray:
        """Torque vector (dyn·cm, axes I, O, S) on the float for specific force ``a`` (g, shape (..., 3)); Hu 2-12,
        2-14, 2-16 in vector form, plus M_F0 about OA."""
        sf = -G0_CGS * np.asarray(a, dtype=float)  # Hu's SF: gravity, toward the ground
        q = np.asarray(self.q, dtype=float)
        delta = self.m * np.einsum("ij,...j->...i", q, sf)
        m_vec = np.cross(np.asarray(self.l, float), self.m * sf) + np.cross(delta, self.m * sf)
        return m_vec + np.array([0.0, self.M_F0, 0.0])

    def drift(self, a) -> np.ndarray:
        """Drift rate about IA (deg/h) for specific force ``a`` (g): ω_d = −M_O/H (Hu 2-27)."""
        return -self.torque(a)[..., 1] / self.H / units.DEG_PER_H


def drift_coefficients(p: PhysicalSDF) -> dict:
    """conventions §6 drift coefficients (deg/h, deg/h/g, deg/h/g²) of a physical gyro (module doc)."""
    k = np.asarray(p.q, dtype=float)
    i, o, s = 0, 1, 2
    to = 1.0 / units.DEG_PER_H
    c = p.m**2 * G0_CGS**2 / p.H * to
    u = p.m * G0_CGS / p.H * to
    return {
        "D_F": -p.M_F0 / p.H * to,
        "D_I": u * p.l[s],
        "D_S": -u * p.l[i],
        "D_II": -c * k[s, i],
        "D_SS": c * k[i, s],
        "D_IS": -c * (k[s, s] - k[i, i]),
        "D_IO": -c * k[s, o],
        "D_OS": c * k[i, o],
    }


def physical_from_drift(coefficients: dict, H: float, m: float) -> PhysicalSDF:
    """A physical gyro (angular momentum ``H`` g·cm²/s, float mass ``m`` g) with the given drift coefficients.

    Unobservable parts are zero (module doc); D_O and D_OO, which no unbalance or compliance produces, are refused.
    """
    for name in ("D_O", "D_OO"):
        if coefficients.get(name, 0.0):
            raise ValueError(f"{name} has no physical cause in the unbalance/compliance model (Hu 2-24)")
    to = 1.0 / units.DEG_PER_H
    c = m**2 * G0_CGS**2 / H * to
    u = m * G0_CGS / H * to
    get = lambda n: float(coefficients.get(n, 0.0))  # noqa: E731
    k = np.zeros((3, 3))
    k[2, 0] = -get("D_II") / c
    k[0, 2] = get("D_SS") / c
    k[2, 2] = -get("D_IS") / c
    k[2, 1] = -get("D_IO") / c
    k[0, 1] = get("D_OS") / c
    l_vec = (-get("D_S") / u, 0.0, get("D_I") / u)
    return PhysicalSDF(H=H, m=m, l=l_vec, q=tuple(map(tuple, k)), M_F0=-get("D_F") * H / to)
