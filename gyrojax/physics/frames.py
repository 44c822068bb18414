"""The local level frame L (ENU) at the test site: Earth rate, gravity and specific force (conventions §2).

All functions but :func:`site_gravity` are pure JAX and differentiable in the latitude.
"""

import functools
import math

import jax
import jax.numpy as jnp

from gyrojax import units


def earth_rate_enu(latitude_rad):
    """Earth rate in L, rad/s: Ω = ω_ie (0, cos φ, sin φ) (conventions §2; Hu 3-13)."""
    return units.OMEGA_IE * jnp.stack([jnp.zeros_like(latitude_rad), jnp.cos(latitude_rad), jnp.sin(latitude_rad)])


def normal_gravity(latitude_rad):
    """WGS-84 normal gravity on the ellipsoid (height 0), m/s², Somigliana's closed form.

    γ(φ) = γ_e (1 + k sin²φ) / √(1 − e² sin²φ)   (NIMA TR8350.2 eq. 4-1).
    """
    s2 = jnp.sin(latitude_rad) ** 2
    return units.WGS84_GAMMA_E * (1.0 + units.WGS84_K * s2) / jnp.sqrt(1.0 - units.WGS84_E2 * s2)


@functools.lru_cache(maxsize=64)
def site_gravity(latitude_deg: float | None) -> float:
    """|g| at a site of ``latitude_deg`` (deg) where no gravity is stated, m/s²: WGS-84 normal gravity at the latitude,
    height 0 (:func:`normal_gravity`; conventions §2); standard gravity g0 when the latitude is unknown (None), within
    0.3 % of every site's."""
    if latitude_deg is None:
        return units.G0
    with jax.ensure_compile_time_eval():  # a number, also where a caller is being traced
        return float(normal_gravity(math.radians(latitude_deg)))


def specific_force_enu(gravity_mps2):
    """Specific force of a body at rest in L, m/s²: f = (0, 0, +g) — the reaction to gravity points up."""
    g = jnp.asarray(gravity_mps2, dtype=jnp.float64)
    return jnp.stack([jnp.zeros_like(g), jnp.zeros_like(g), g])
