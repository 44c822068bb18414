"""The local level frame L (ENU) at the test site: Earth rate, gravity and specific force (conventions §2).

All functions are pure JAX and differentiable in the latitude (a site's gravity as a number without JAX:
:mod:`gyrojax.physics.gravity`).
"""

import jax.numpy as jnp

from gyrojax import units
from gyrojax.physics.gravity import somigliana


def earth_rate_enu(latitude_rad):
    """Earth rate in L, rad/s: Ω = ω_ie (0, cos φ, sin φ) (conventions §2; Hu 3-13)."""
    return units.OMEGA_IE * jnp.stack([jnp.zeros_like(latitude_rad), jnp.cos(latitude_rad), jnp.sin(latitude_rad)])


def normal_gravity(latitude_rad):
    """WGS-84 normal gravity on the ellipsoid (height 0), m/s², at ``latitude_rad`` (rad):
    :func:`gyrojax.physics.gravity.somigliana` of sin²φ, traced."""
    return somigliana(jnp.sin(latitude_rad) ** 2)


def specific_force_enu(gravity_mps2):
    """Specific force of a body at rest in L, m/s²: f = (0, 0, +g) — the reaction to gravity points up."""
    g = jnp.asarray(gravity_mps2, dtype=jnp.float64)
    return jnp.stack([jnp.zeros_like(g), jnp.zeros_like(g), g])
