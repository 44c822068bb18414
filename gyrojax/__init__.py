"""gyrojax: identify gyroscope error coefficients from turntable tests.

The gyro error model, turntable kinematics and loops are pure, jitted JAX functions (float64), so that
identification and test-plan design are gradient-based and Monte Carlo studies are one ``vmap`` away.
Units and names follow the conventions (docs/conventions.md; deg/h, deg/h/g, ppm, arcsec at the surface; SI inside).

The package is a tree that follows the data flow::

    physics/     frames, kinematics, effect registry + built-ins, the measurement model
    data/        records, truth files, plans (schema + builders), file I/O
    simulation/  records from a plan and a truth (quasi-static or through the loops)
    noise/       noise description and processes, whitening / REML, Allan variance, AR analysis
    inference/   fit (GLS, honest σ), big records, diagnosis of missing effects
    planning/    test-plan design by Fisher information
    montecarlo/  studies over many simulated gyros
    adaptive/    the test campaign as a loop: the next test from the records so far, until the goal is met
    dynamics/    ZOH discretisation, rebalance / servo / TDF loops, loop-aware fits
    seeds/       the source books' closed forms and systems
    report/      tables, text and figures (the only library package that draws)
    cli/         the ``gyrojax`` command (the only package that parses arguments)

and below them the modules every package may import: ``errors``, ``units``, ``kinds`` (the instrument kinds),
``protocol`` (files and the result protocol) and ``runtime`` (how compiled code runs: gyrojax's cache folder, its
kept executables, its threads). Importing the package sets JAX's x64 and nothing else global: gyrojax keeps its own
compiled functions (:mod:`gyrojax.runtime.kept`), and JAX's persistent compilation cache stays the process owner's
choice. Imports point down a declared layer order (tests/test_layers.py).

``import gyrojax as gj`` gives the flat API: ``gj.simulate``, ``gj.load_records``, ``gj.fit``,
``gj.diagnose``, ``gj.add_and_refit``, ``gj.design``, ``gj.next_test``, ``gj.run_campaign``, ``gj.run_study`` …
(loaded on first use, so that
``import gyrojax`` stays fast).
"""

import importlib
import os
import sys

from gyrojax.errors import (
    GyrojaxError,
    ModelError,
    PlanError,
    RecordError,
    TruthError,
    UnknownNameError,
)


def _enable_x64() -> None:
    """float64 in JAX, the one place: drifts of 1e-4 deg/h beside rates of 1e5 deg/h. JAX itself is not imported
    here (``gyrojax --help``, ``gyrojax plans`` and ``gyrojax import`` never need it): before its import, its
    ``JAX_ENABLE_X64`` variable makes float64 the default; if JAX is already imported, its config is updated."""
    if "jax" in sys.modules:
        sys.modules["jax"].config.update("jax_enable_x64", True)
    else:
        os.environ["JAX_ENABLE_X64"] = "1"


_enable_x64()

__version__ = "0.2.0"

_FLAT = {
    # modules
    "effects": "gyrojax.physics.effects",
    "frames": "gyrojax.physics.frames",
    "kinematics": "gyrojax.physics.kinematics",
    "plans": "gyrojax.data.plans",
    "noise": "gyrojax.noise",
    "units": "gyrojax.units",
    "report": "gyrojax.report",
    # physics
    "Effect": "gyrojax.physics.registry:Effect",
    "register": "gyrojax.physics.registry:register",
    "Model": "gyrojax.physics.model:Model",
    "predict": "gyrojax.physics.model:predict",
    "record_data": "gyrojax.data.arrays:record_data",
    # data
    "Record": "gyrojax.data.record:Record",
    "load_record": "gyrojax.data.records:load_record",
    "load_records": "gyrojax.data.records:load_records",
    "save_record": "gyrojax.data.records:save_record",
    "Truth": "gyrojax.data.truth:Truth",
    "TriadTruth": "gyrojax.data.truth:TriadTruth",
    "load_truth": "gyrojax.data.truth:load_truth",
    "truth_from_dict": "gyrojax.data.truth:truth_from_dict",
    "Plan": "gyrojax.data.plans:Plan",
    "load_plan": "gyrojax.data.planfile:load_plan",
    # simulation
    "simulate": "gyrojax.simulation.simulator:simulate",
    # inference
    "Campaign": "gyrojax.inference.campaign:Campaign",
    "FitResult": "gyrojax.inference.result:FitResult",
    "fit": "gyrojax.inference.identify:fit",
    "Diagnosis": "gyrojax.inference.verdict:Diagnosis",
    "diagnose": "gyrojax.inference.diagnose:diagnose",
    "add_and_refit": "gyrojax.inference.diagnose:add_and_refit",
    "fit_with": "gyrojax.inference.diagnose:fit_with",
    "fit_chunked": "gyrojax.inference.bigfit:fit_chunked",
    # noise
    "allan": "gyrojax.noise.allan:allan",
    # planning
    "design": "gyrojax.planning.design:design",
    "compare_plans": "gyrojax.planning.baselines:compare",
    # the campaign loop
    "Goal": "gyrojax.adaptive.goal:Goal",
    "Lab": "gyrojax.adaptive.lab:Lab",
    "HandLab": "gyrojax.adaptive.hand:HandLab",
    "next_test": "gyrojax.adaptive.step:next_test",
    "run_campaign": "gyrojax.adaptive.simulated:run_campaign",
    "run_hand_campaign": "gyrojax.adaptive.simulated:run_hand_campaign",
    # Monte Carlo
    "Study": "gyrojax.montecarlo.study:Study",
    "load_study": "gyrojax.montecarlo.study:load_study",
    "run_study": "gyrojax.montecarlo.runner:run_study",
}

__all__ = ["GyrojaxError", "ModelError", "PlanError", "RecordError", "TruthError", "UnknownNameError", "__version__"]
__all__ += sorted(_FLAT)


def __getattr__(name: str):
    """Load a name of the flat API on first use (PEP 562)."""
    target = _FLAT.get(name)
    if target is None:
        raise AttributeError(f"module 'gyrojax' has no attribute {name!r}")
    module, _, attr = target.partition(":")
    value = importlib.import_module(module)
    if attr:
        value = getattr(value, attr)
    globals()[name] = value
    return value


def __dir__():
    return __all__
