"""Optical gyros: Sagnac scale factors, the IEEE 952-form instrument model and ring-laser lock-in (Titterton ch. 5, 8).

**Sagnac.** RLG beat frequency Δν = 4AΩ/(λL) (Titterton 5.11; the first printed form "4AΩ/(cL)" is garbled), one
output pulse per Δθ = λL/(4A) (5.13), for an equilateral triangle of path L: Δθ = 3√3 λ/L (5.15): 2.25″ for
L = 30 cm at 632.8 nm. IFOG phase ΔΦ = 4πRLΩ/(cλ) for fibre length L on a coil of radius R (5.20).

**Instrument model** (Titterton 5.16 = 8.4; the IEEE 952 form for a single-axis optical gyro)::

    ω̃_x = (1 + S_x) ω_x + M_y ω_y + M_z ω_z + B_x + n_x

with scale-factor error S_x, misalignments M_y, M_z, fixed bias B_x and random bias n_x (angle random walk N in
deg/√h, bias instability, rate random walk).

**Lock-in** (RLG; Titterton §5.1.3.4 describes it, the model is Aronowitz's, cited there as ref. [6] of ch. 5).
The beam phase difference ψ obeys the Adler equation ψ̇ = K (Ω − Ω_L sin ψ). Inside the lock band |Ω| ≤ Ω_L it
settles at sin ψ = Ω/Ω_L and the output is zero; outside it turns with period 2π/(K√(Ω² − Ω_L²)), so the mean
output rate (in input-rate units) is

    Ω_out = sign(Ω) √(Ω² − Ω_L²)    for |Ω| > Ω_L,     0 otherwise.

**Registered effect.** ``lock_in`` (coefficient ``Omega_L``, deg/h) for the instrument kind ``"rlg"``: it adds
Ω_out(ω_I) − ω_I to the indicated rate, so a :class:`gyrojax.physics.model.Model` of kind ``"rlg"`` predicts the
dead band.
``Model`` and ``indicated_output`` accept the new kind unchanged (it takes the SDF input names ω_I, ω_O, ω_S and
the base output ω_I). Records declare ``"kind": "fog"`` or ``"rlg"`` with ``ia``, ``oa``, ``sa`` like an SDF gyro, and
the bias, scale-factor, misalignment, trend and temperature effects of conventions §6 apply to them (``D_F``,
``sf_error``, ``sf_asymmetry``, ``sf_quadratic``, ``ia_misalignment``, ``bias_trend``, ``bias_temperature``: the
terms of Titterton 5.16 / IEEE 952); g-sensitive drift terms do not.

Units: rates in deg/h at the surface (any consistent unit for the pure functions), SI for lengths and wavelengths.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from gyrojax.physics.effects import FOG, RLG, lockin_output

C_LIGHT = 299_792_458.0
"""Speed of light, m/s."""

__all__ = [
    "FOG",
    "RLG",
    "adler_phase",
    "fog_sagnac_phase",
    "ieee952_output",
    "lockin_output",
    "rlg_pulse_angle",
    "rlg_triangle_pulse_angle",
]


def rlg_pulse_angle(area_m2, path_m, wavelength_m=632.8e-9):
    """Input angle per output pulse of a ring laser, Δθ = λL/(4A), rad (Titterton 5.13)."""
    return wavelength_m * path_m / (4.0 * area_m2)


def rlg_triangle_pulse_angle(path_m, wavelength_m=632.8e-9):
    """Δθ = 3√3 λ/L for an equilateral triangular cavity of perimeter L, rad (Titterton 5.14–5.15)."""
    return 3.0 * jnp.sqrt(3.0) * wavelength_m / path_m


def fog_sagnac_phase(rate_rad_s, coil_radius_m, fibre_length_m, wavelength_m=850e-9):
    """IFOG Sagnac phase ΔΦ = 4πRLΩ/(cλ), rad (Titterton 5.20)."""
    return 4.0 * jnp.pi * coil_radius_m * fibre_length_m * rate_rad_s / (C_LIGHT * wavelength_m)


def ieee952_output(w_x, w_y, w_z, scale_error=0.0, m_y=0.0, m_z=0.0, bias=0.0):
    """ω̃_x = (1 + S_x) ω_x + M_y ω_y + M_z ω_z + B_x (Titterton 5.16 / 8.4); S, M dimensionless, rates any unit."""
    return (1.0 + scale_error) * w_x + m_y * w_y + m_z * w_z + bias


def adler_phase(rate, lock_rate, dt, n, psi0=0.0):
    """Integrate ψ̇ = Ω(t) − Ω_L sin ψ (K = 1) by RK4 in ``lax.scan``; ``rate`` scalar or (n,) held per step.

    Returns ψ at t = 0, dt, …, n·dt (n + 1 values). Units: Ω and Ω_L in rad/s, ψ in rad (an input angle).
    """
    rates = jnp.broadcast_to(jnp.asarray(rate, jnp.float64), (n,))

    def f(psi, w):
        return w - lock_rate * jnp.sin(psi)

    def step(psi, w):
        k1 = f(psi, w)
        k2 = f(psi + 0.5 * dt * k1, w)
        k3 = f(psi + 0.5 * dt * k2, w)
        k4 = f(psi + dt * k3, w)
        psi = psi + dt / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
        return psi, psi

    psi0 = jnp.asarray(psi0, jnp.float64)
    _, out = jax.lax.scan(step, psi0, rates)
    return jnp.concatenate([psi0[None], out])
