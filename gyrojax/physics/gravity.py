"""Gravity at the test site (conventions §2), without JAX: the importers and the command line take it before any
arithmetic is compiled. :func:`gyrojax.physics.frames.normal_gravity` is the same closed form, traced."""

import math

from gyrojax import units


def somigliana(sin2_latitude):
    """WGS-84 normal gravity on the ellipsoid (height 0), m/s², from sin²φ (a float or an array of any namespace):
    γ(φ) = γ_e (1 + k sin²φ) / √(1 − e² sin²φ), Somigliana's closed form (NIMA TR8350.2 eq. 4-1)."""
    return units.WGS84_GAMMA_E * (1.0 + units.WGS84_K * sin2_latitude) / (1.0 - units.WGS84_E2 * sin2_latitude) ** 0.5


def site_gravity(latitude_deg: float | None) -> float:
    """|g| at a site of ``latitude_deg`` (deg) where no gravity is stated, m/s²: WGS-84 normal gravity at the latitude,
    height 0 (:func:`somigliana`); standard gravity g0 when the latitude is unknown (None), within 0.3 % of every
    site's."""
    if latitude_deg is None:
        return units.G0
    return float(somigliana(math.sin(math.radians(latitude_deg)) ** 2))
