"""gyrojax's own error types. Everything a user can get wrong raises one of these with a message that names
the file and the key, or the row and the column, and says what would be valid."""


class GyrojaxError(Exception):
    """Base class of every error gyrojax raises on purpose."""


class RecordError(GyrojaxError, ValueError):
    """A record file (conventions §5) is malformed."""


class PlanError(GyrojaxError, ValueError):
    """A test plan is malformed."""


class TruthError(GyrojaxError, ValueError):
    """A truth file (conventions §8) is malformed."""


class ModelError(GyrojaxError, ValueError):
    """An effect list is invalid for an instrument, or a plan cannot identify a model."""


class UnknownNameError(ModelError, KeyError):
    """An effect or coefficient name that is not registered (a ``KeyError`` too, for dict-like callers)."""

    def __str__(self) -> str:  # KeyError would quote the message
        return str(self.args[0]) if self.args else ""


class FormatError(GyrojaxError, ValueError):
    """A saved file (fit result, study) is not of the format or version this gyrojax reads."""


class ConvergenceWarning(UserWarning):
    """An iterative step of a fit (the nonlinear set-up terms, the noise model) stopped before it converged: the
    numbers are reported, but the result says ``"converged": false`` and why."""
