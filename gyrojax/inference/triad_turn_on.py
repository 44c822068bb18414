"""The bias of each power-up of a triad: ``bias_turn_on`` as a term of the triad fit (conventions §9.3).

A MEMS gyro's bias changes from one turn-on to the next (IEEE 1431's turn-on to turn-on bias repeatability) and
stays while the instrument runs. Records of one instrument (``instrument.id``) are its power-ups, in the order they
are given: power-up k + 1 carries the bias of the first, D_F[c], plus a step D_F_step_<k>[c] (deg/h) on each channel
c. The step is a constant added to the indicated rate of every sample of that power-up, so it acts as D_F does:

* on a **rest or rotation** mean, its column is that of D_F[c] on the segments of the power-up (1 on channel c's
  row), and 0 elsewhere: the segment means stay linear in every coefficient;
* on a **gravity-to-gravity move**, the channel model is solved for the body rate from the indicated rate less the
  power-up's bias, so the move's residual at the steps β is the residual at the channel coefficients with the move's
  indicated samples lowered by β (:func:`shifted_moves`), and its derivative in β is exactly its derivative in
  D_F[c] there (the Jacobian of :func:`gyrojax.inference.triad_rows.move_rows`, the D_F columns taken on the moves
  of that power-up).

θ of a fit with the term is the channel coefficients (3p, as without it) followed by the steps of power-ups 2, 3, …,
each on x, y, z (:func:`step_names`). The fit refuses the term, naming why, where it cannot be fitted: one record
(one power-up has no step), a model without D_F (the first power-up's bias the steps are counted from), or a
power-up after the first without a rest (its bias would be seen through its moves' integrated angle alone).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gyrojax.errors import ModelError
from gyrojax.inference.triad_rows import move_rows
from gyrojax.physics import triad as tp

TURN_ON = "bias_turn_on"
"""The effect name of the steps (conventions §9.3): not an effect of §6, the triad fit's own term."""
STEP = "D_F_step"
"""The steps' coefficient stem: ``D_F_step_<k>[<channel>]``, deg/h, the bias of power-up k + 1 less the first's."""
BIAS = "D_F"


def split_terms(terms) -> tuple[tuple, bool]:
    """(``terms`` without ``bias_turn_on``, whether it was among them)."""
    terms = tuple(terms)
    return tuple(t for t in terms if t != TURN_ON), TURN_ON in terms


def step_names(power_ups: int) -> list[str]:
    """The coefficient names of the steps of ``power_ups`` power-ups (none for one), power-up after power-up, each on
    x, y, z: ``D_F_step_1[x]`` …"""
    return [tp.channel_name(f"{STEP}_{k}", ch) for k in range(1, power_ups) for ch in tp.CHANNELS]


def is_step(name: str) -> bool:
    """True for a step's coefficient name ``D_F_step_<k>[<channel>]``."""
    return name.startswith(f"{STEP}_")


@dataclass(frozen=True)
class PowerUps:
    """Which power-up each segment and each move of a fit belongs to, and where D_F of each channel sits in the
    channel coefficients. ``count`` 1: no steps (every method then returns its input as it is)."""

    segment: np.ndarray  # (m,) power-up index of each rest or rotation, 0-based
    move: np.ndarray  # (M,) power-up index of each move
    count: int
    bias_columns: tuple = ()  # index of D_F[x], D_F[y], D_F[z] in the channel θ (3p,)
    channel_size: int = 0  # 3p

    @property
    def n_steps(self) -> int:
        """Number of step coefficients, 3 (count − 1)."""
        return 3 * (self.count - 1)

    def split(self, theta) -> tuple[np.ndarray, np.ndarray]:
        """(channel θ (3p,), each power-up's step (count, 3) deg/h, the first's zero) of a full θ."""
        th = np.asarray(theta, dtype=float)
        steps = np.zeros((self.count, 3))
        if self.n_steps:
            steps[1:] = th[self.channel_size :].reshape(-1, 3)
        return th[: self.channel_size] if self.n_steps else th, steps

    def bias_of(self, theta, index) -> np.ndarray:
        """The step (…, 3) deg/h of the power-ups ``index`` (one index or an array of them) at θ (0 without steps)."""
        steps = self.split(theta)[1]
        return steps[index] if self.n_steps else np.zeros(np.shape(index) + (3,))

    def segment_jacobian(self, jac: np.ndarray) -> np.ndarray:
        """``jac`` (3m, 3p) of the segment means with the steps' columns after it (3m, 3p + 3 (count − 1)): D_F[c]'s
        column on the segments of each power-up after the first."""
        return self._with_steps(jac, self.segment, 3)

    def shifted_moves(self, packed: tuple, theta) -> tuple:
        """The packed moves (:func:`gyrojax.inference.triad_rows.pack_moves`) with each move's indicated samples
        lowered by its power-up's step at θ (padded moves as they are)."""
        if not self.n_steps:
            return packed
        g = np.array(packed[0])
        g[: len(self.move)] -= self.bias_of(theta, self.move)[:, None, :]
        return (g, *packed[1:])

    def move_jacobian(self, mj: np.ndarray) -> np.ndarray:
        """The moves' Jacobian ``mj`` (2M, 3p) with the steps' columns after it: D_F[c]'s columns on the two rows of
        each move of a power-up after the first."""
        return self._with_steps(mj, self.move, 2)

    def _with_steps(self, jac: np.ndarray, power_up: np.ndarray, rows_each: int) -> np.ndarray:
        """``jac`` with the steps' columns: D_F's columns on the rows (``rows_each`` per item) of each power-up's
        items (``power_up``: the power-up of each), 0 on the first's."""
        if not self.n_steps:
            return jac
        cols = np.zeros((jac.shape[0], self.n_steps))
        rows = np.repeat(power_up, rows_each)
        for k in range(1, self.count):
            cols[:, 3 * (k - 1) : 3 * k] = jac[:, list(self.bias_columns)] * (rows == k)[:, None]
        return np.hstack([jac, cols])


def power_ups(model, segment_record, move_record, n_records: int, fitted: bool) -> PowerUps:
    """The :class:`PowerUps` of a fit of ``model`` (the channel model) to ``n_records`` records: each segment's and
    move's record index; ``fitted`` False (the term not asked for): one power-up, no steps."""
    seg, mv = np.asarray(segment_record, dtype=int), np.asarray(move_record, dtype=int)
    if not fitted:
        return PowerUps(seg, mv, 1)
    names = model.coefficient_names
    bias = tuple(c * model.size + names.index(BIAS) for c in range(3))
    return PowerUps(seg, mv, n_records, bias, 3 * model.size)


def check(model, record_names: list, segments_per_record: list) -> None:
    """Refuse ``bias_turn_on`` where it cannot be fitted (module doc), naming why: ``record_names`` the records in
    order, ``segments_per_record`` the kinds of each one's rest and rotation segments."""
    if len(record_names) < 2:
        raise ModelError(
            f"{TURN_ON} fits one bias per power-up after the first and needs records of two or more power-ups of one "
            f"instrument; {len(record_names)} record given"
        )
    if BIAS not in model.terms:
        raise ModelError(f"{TURN_ON} counts each power-up's bias from the first's, D_F: add D_F to the terms")
    for name, kinds in list(zip(record_names, segments_per_record))[1:]:
        if "static" not in kinds:
            raise ModelError(
                f"{TURN_ON}: power-up {name!r} has no rest, so its bias (D_F_step) could be seen only through the "
                "angles its moves integrate; record rests in every power-up or fit without bias_turn_on"
            )


def move_rows_with_steps(model, theta, packed, whitening, pu: PowerUps):
    """:func:`gyrojax.inference.triad_rows.move_rows` at a full θ (channel coefficients, then the steps): the moves'
    residual (M, 3), whitened rows (2M,) and Jacobian (2M, 3p + 3 (count − 1)) (module doc)."""
    th, _ = pu.split(theta)
    r, rows, mj = move_rows(model, th, pu.shifted_moves(packed, theta), whitening)
    return r, rows, pu.move_jacobian(mj)
