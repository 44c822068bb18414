"""The effect registry (conventions §6): the :class:`Effect` type and the table of named effects.

Each effect is one small, frozen object: its canonical name, its coefficients with their report units, a one-line
physical description, the seed reference, flags that tell the measurement model how to treat it, and a pure
function giving its contribution to the indicated output from the instrument inputs.

Instrument inputs are a dict of arrays (one entry per sample):

    w_I, w_O, w_S      angular rate about IA, OA, SA            deg/h
    a_I, a_O, a_S      specific force along IA, OA, SA          g (g0 = 9.80665 m/s²)
    t_h                time since the campaign clock's zero      h
    temperature_C      instrument temperature                    °C
    (TDF gyros: w_X, w_Y, a_X, a_Y, a_Z; accelerometers: a_I, a_P, a_O)

A *setup* effect (``table_tilt``, ``table_azimuth``, ``encoder_harmonic``) has no contribution of its own: it
changes the kinematics (the base orientation or the angle read), and the measurement model applies it there.

The built-in effects live in :mod:`gyrojax.physics.effects`, which registers them all when it is imported (as
``import gyrojax`` does). Adding an effect of your own takes a few lines::

    from gyrojax.physics.effects import Effect, register
    register(Effect(
        name="D_I_trend", coefficients=("D_IT",), units=("deg/h/g/h",), kinds=("sdf-gyro",),
        contribution=lambda x, c: c[0] * x["a_I"] * x["t_h"],
        description="g-sensitivity that drifts in time", reference="user"))

after which ``"D_I_trend"`` is accepted by ``fit``, ``diagnose`` and the simulator like any built-in name.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from gyrojax.errors import UnknownNameError


@dataclass(frozen=True)
class Effect:
    """One named physical effect.

    Attributes:
      name: canonical name (conventions §6), e.g. ``"D_IS"``.
      coefficients: names of its coefficients, e.g. ``("M_O", "M_S")``.
      units: report unit of each coefficient.
      kinds: instrument kinds it applies to.
      contribution: ``f(inputs, c) -> array`` in the output unit (deg/h for gyros, g for accelerometers),
        with ``c`` the coefficients in report units; ``None`` for setup effects.
      description: the physics in one line.
      reference: seed equation numbers.
      setup: True for effects of the test set (table, encoder) rather than of the instrument.
      linear: True when the output is linear in the coefficients (identification then needs one solve).
      linear_in_rate: False when the output is not linear in the input rate (scale-factor asymmetry or
        nonlinearity, lock-in): a servo record then needs the table rate solved for, not divided out.
      knee: the instrument input (e.g. ``"temperature_C"``) along which the effect's last coefficient places a
        knee: the output is linear in the other coefficients once the knee is fixed, and the knee is seen only when
        they are not zero, so a fit starts it from a profile over the input's recorded range and a diagnosis tests
        the effect by the supremum of its score over the knee (:mod:`gyrojax.inference.knee`); None for none.
    """

    name: str
    coefficients: tuple[str, ...]
    units: tuple[str, ...]
    kinds: tuple[str, ...]
    contribution: Callable | None
    description: str
    reference: str
    setup: bool = False
    linear: bool = True
    linear_in_rate: bool = True
    knee: str | None = None

    @property
    def size(self) -> int:
        """Number of coefficients the effect carries."""
        return len(self.coefficients)


_REGISTRY: dict[str, Effect] = {}


def register(effect: Effect) -> Effect:
    """Add an effect to the library (replacing none: names are unique)."""
    if effect.name in _REGISTRY:
        raise ValueError(f"effect {effect.name!r} is already registered")
    clash = {c for e in _REGISTRY.values() for c in e.coefficients} & set(effect.coefficients)
    if clash:
        raise ValueError(f"coefficient names {sorted(clash)} of {effect.name!r} are already used")
    _REGISTRY[effect.name] = effect
    return effect


BUILTIN: set[str] = set()
"""Names of the built-in effects (:mod:`gyrojax.physics.effects` adds them on import); they cannot be unregistered."""


def unregister(name: str) -> None:
    """Remove an effect registered by the user (built-ins stay, :data:`BUILTIN`);
    :class:`~gyrojax.errors.UnknownNameError` when ``name`` is not registered."""
    if name not in _REGISTRY:
        raise UnknownNameError(f"unknown effect {name!r}")
    if name in BUILTIN:
        raise ValueError(f"effect {name!r} is built in and cannot be removed")
    del _REGISTRY[name]


def get(name: str) -> Effect:
    """The effect called ``name``; :class:`~gyrojax.errors.UnknownNameError` listing the valid names otherwise."""
    try:
        return _REGISTRY[name]
    except KeyError:
        raise UnknownNameError(f"unknown effect {name!r}; valid names: {', '.join(_REGISTRY)}") from None


def names(kind: str | None = None, setup: bool | None = None) -> list[str]:
    """Names of the registered effects, optionally only those for an instrument kind / of the test set."""
    return [
        e.name for e in _REGISTRY.values() if (kind is None or kind in e.kinds) and (setup is None or e.setup == setup)
    ]


def coefficient_index() -> dict[str, tuple[str, int]]:
    """Map coefficient name → (effect name, position inside the effect)."""
    return {c: (e.name, i) for e in _REGISTRY.values() for i, c in enumerate(e.coefficients)}


def effect_of_coefficient(coefficient: str) -> str:
    """Name of the effect that carries ``coefficient`` (``"E_SF"`` → ``"sf_error"``)."""
    idx = coefficient_index()
    if coefficient not in idx:
        raise UnknownNameError(f"unknown effect or coefficient {coefficient!r}; valid coefficients: {', '.join(idx)}")
    return idx[coefficient][0]
