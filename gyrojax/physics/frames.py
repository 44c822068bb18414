"""The local level frame L (ENU) at the test site: Earth rate and specific force (conventions §2).

All functions are pure JAX and differentiable in the latitude.
"""

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


def specific_force_enu(gravity_mps2):
    """Specific force of a body at rest in L, m/s²: f = (0, 0, +g) — the reaction to gravity points up."""
    g = jnp.asarray(gravity_mps2, dtype=jnp.float64)
    return jnp.stack([jnp.zeros_like(g), jnp.zeros_like(g), g])
