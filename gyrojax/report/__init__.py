"""Readable faces of the results: coefficient tables and diagnosis text (:mod:`gyrojax.report.text`), residual
views and study figures (:mod:`gyrojax.report.figures`, pyplot-free), and the hidden-effect walkthrough
(:mod:`gyrojax.report.demo`).

Names are loaded on first use (PEP 562), so that ``gyrojax.report.text`` does not import matplotlib.
"""

from importlib import import_module

_WHERE = {
    "fit_table": "text",
    "diagnosis_text": "text",
    "adequacy_lines": "text",
    "allan_figure": "figures",
    "campaign_figure": "figures",
    "candidates_figure": "figures",
    "design_figure": "figures",
    "error_falling_figure": "figures",
    "harmonic_spectrum": "figures",
    "measurement_inputs": "figures",
    "montecarlo_figure": "figures",
    "residual_figure": "figures",
    "save": "figures",
}

__all__ = sorted(_WHERE)


def __getattr__(name):
    if name in _WHERE:
        return getattr(import_module(f"gyrojax.report.{_WHERE[name]}"), name)
    if name in ("text", "figures", "demo"):
        return import_module(f"gyrojax.report.{name}")
    raise AttributeError(f"module 'gyrojax.report' has no attribute {name!r}")


def __dir__():
    return sorted(list(_WHERE) + ["text", "figures", "demo"])
