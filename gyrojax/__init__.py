"""gyrojax: identify gyroscope error coefficients from turntable tests.

The gyro error model, turntable kinematics and loops are pure, jitted JAX functions (float64), so that
identification and test-plan design are gradient-based and Monte Carlo studies are one ``vmap`` away.
Units and names follow CONVENTIONS (deg/h, deg/h/g, ppm, arcsec at the surface; SI inside).
"""

import jax

jax.config.update("jax_enable_x64", True)

from . import effects, frames, kinematics, noise, plans, units  # noqa: E402
from .effects import Effect, register  # noqa: E402
from .errors import GyrojaxError, ModelError, PlanError, RecordError, TruthError  # noqa: E402
from .model import Model, predict, record_data  # noqa: E402
from .records import Record, load_record, load_records, save_record  # noqa: E402
from .simulate import simulate  # noqa: E402
from .truth import Truth, load_truth, truth_from_dict  # noqa: E402

__version__ = "0.1.0"

__all__ = [
    "Effect", "GyrojaxError", "Model", "ModelError", "PlanError", "Record", "RecordError", "Truth", "TruthError",
    "effects", "frames", "kinematics", "load_record", "load_records", "load_truth", "noise", "plans", "predict",
    "record_data", "register", "save_record", "simulate", "truth_from_dict", "units", "__version__",
]
