"""What the ``gyrojax`` command reads from its arguments: the usage error, the parsers of option values that the
sub-commands share (plan options, term lists, a Gauss–Markov pair) and the refusal to write over records. Below
both :mod:`gyrojax.cli.app` (the parser and ``main``) and :mod:`gyrojax.cli.commands` (what each sub-command does),
so neither imports the other's module at import time.
"""

from __future__ import annotations

import json
from pathlib import Path

from gyrojax.errors import GyrojaxError


class UsageError(GyrojaxError):
    """Bad command-line arguments."""


def parse_options(pairs) -> dict:
    """``["NAME=VALUE", …]`` → ``{name: value}`` (values parsed as JSON where they are JSON; ``-`` → ``_``)."""
    out = {}
    for p in pairs or []:
        if "=" not in p:
            raise UsageError(f"plan option {p!r} must look like NAME=VALUE")
        k, v = p.split("=", 1)
        try:
            value = json.loads(v)
        except json.JSONDecodeError:
            value = v
        out[k.replace("-", "_")] = value
    return out


def parse_terms(s: str | None) -> list[str]:
    """A comma-separated list of effect names → list (empty for ``None``)."""
    if s is None:
        return []
    return [t.strip() for t in s.split(",") if t.strip()]


def parse_gm(text: str | None, option: str = "--gm") -> tuple[float, float] | None:
    """``"sigma_deg_per_h,tau_s"`` → (σ, τ), both finite and positive; :class:`UsageError` naming the option."""
    if text is None:
        return None
    parts = text.split(",")
    try:
        if len(parts) != 2:
            raise ValueError
        sigma, tau = (float(x) for x in parts)
    except ValueError:
        raise UsageError(f"{option} {text!r}: expected 'sigma_deg_per_h,tau_s', e.g. 0.05,300") from None
    if not (sigma > 0 and tau > 0 and sigma < float("inf") and tau < float("inf")):
        raise UsageError(f"{option} {text!r}: sigma and tau must be finite and positive")
    return sigma, tau


def save_new_records(records, out, force: bool) -> list[Path]:
    """Write ``records`` into the folder ``out``; without ``force``, nothing when a file of one of them exists
    (:class:`UsageError` naming it). Returns the JSON paths."""
    from gyrojax.data.records import record_paths, save_record

    out = Path(out)
    if not force:
        for r in records:
            for p in record_paths(out / r.name):
                if p.exists():
                    raise UsageError(f"{p}: exists; pass --force to overwrite")
    return [save_record(r, out, force=True) for r in records]
