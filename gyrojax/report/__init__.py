"""Readable faces of the results: coefficient tables, diagnosis text, residual views and study figures
(:mod:`gyrojax.report.figures`, pyplot-free), and the hidden-effect walkthrough (:mod:`gyrojax.report.demo`)."""

from gyrojax.report.figures import (
    allan_figure,
    candidates_figure,
    design_figure,
    diagnosis_text,
    error_falling_figure,
    fit_table,
    harmonic_spectrum,
    measurement_inputs,
    montecarlo_figure,
    residual_figure,
    save,
)

__all__ = [
    "allan_figure",
    "candidates_figure",
    "design_figure",
    "diagnosis_text",
    "error_falling_figure",
    "fit_table",
    "harmonic_spectrum",
    "measurement_inputs",
    "montecarlo_figure",
    "residual_figure",
    "save",
]
