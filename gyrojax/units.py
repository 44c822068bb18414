"""Units and physical constants (conventions §1).

Inside the package angles are radians and rates rad/s; files, reports and public arguments use deg, deg/h,
arcsec, ppm and g. Every conversion lives here so that no other module carries a bare magic number.
"""

import math

G0 = 9.80665
"""Standard gravity, m/s² (1 g in every error model; conventions §1)."""

OMEGA_IE = 7.2921150e-5
"""Earth rotation rate ω_ie, rad/s (15.04107 deg/h)."""

DEG = math.pi / 180.0
"""One degree in rad."""

ARCSEC = DEG / 3600.0
"""One arcsecond in rad."""

DEG_PER_H = DEG / 3600.0
"""One deg/h in rad/s."""

PPM = 1e-6
"""One part per million (dimensionless)."""

OMEGA_IE_DEG_PER_H = OMEGA_IE / DEG_PER_H
"""Earth rate in deg/h (15.041067...)."""

SECONDS_PER_HOUR = 3600.0
"""Seconds in one hour (s/h)."""

# WGS-84 ellipsoid and normal gravity (Somigliana), NIMA TR8350.2 §4.
WGS84_A = 6378137.0
"""WGS-84 semi-major axis, m."""
WGS84_B = 6356752.3142
"""WGS-84 semi-minor axis, m."""
WGS84_E2 = 6.69437999014e-3
"""WGS-84 first eccentricity squared (dimensionless)."""
WGS84_GAMMA_E = 9.7803253359
"""Normal gravity at the equator, m/s²."""
WGS84_GAMMA_P = 9.8321849378
"""Normal gravity at the poles, m/s²."""
WGS84_K = (WGS84_B * WGS84_GAMMA_P) / (WGS84_A * WGS84_GAMMA_E) - 1.0
"""Somigliana's constant k = b γ_p / (a γ_e) − 1 (dimensionless)."""


def white_sigma_deg_per_h(arw_deg_per_rt_h: float, dt_s: float) -> float:
    """Standard deviation (deg/h) of a rate averaged over ``dt_s`` seconds for angle random walk N (deg/√h).

    σ = N·60/√Δt, since √h = 60 √s (IEEE 952, annex C: σ²(τ) = N²/τ).
    """
    return arw_deg_per_rt_h * 60.0 / math.sqrt(dt_s)


REPORT_UNITS = frozenset(
    {
        "deg/h",  # drift, bias (conventions §6: D_F; §1 angular rate)
        "deg/h/g",  # g-sensitive drift (D_I, D_O, D_S)
        "deg/h/g²",  # g²-sensitive drift (D_II … D_OS)
        "deg/h/h",  # drift trend (D_T)
        "deg/h/°C",  # temperature sensitivity (D_TEMP, D_HINGE)
        "°C",  # a knee along the temperature (T_KNEE)
        "ppm",  # scale-factor errors (E_SF, E_A)
        "ppm/(deg/s)",  # scale-factor nonlinearity (E_2)
        "arcsec",  # small angles: misalignment, table set-up, encoder harmonics
        "g",  # accelerometer bias (K_0)
        "g/g",  # accelerometer scale factor (K_1)
        "g/g²",  # accelerometer second order and cross-coupling (K_2, K_IP, K_IO)
        "g/g³",  # accelerometer third order (K_3)
    }
)
"""The coefficient report units the conventions know (conventions §1 and §6); an effect's ``units`` are drawn from
this set (the effect contract suite checks it), so that every report and file speaks one vocabulary."""
