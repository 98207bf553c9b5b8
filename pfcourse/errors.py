"""Named exceptions raised by pfcourse.

Every error a user can trigger with bad input or a numerically impossible
situation is one of these classes, so notebooks and tests can catch exactly
what went wrong.  Messages say what was wrong and, inside the filter, at which
time step.
"""

from __future__ import annotations


class PfcourseError(Exception):
    """Base class of every error raised on purpose by pfcourse."""


class ShapeError(PfcourseError, ValueError):
    """An array does not have the shape the function needs."""


class CovarianceError(PfcourseError, ValueError):
    """A covariance matrix is not square, not symmetric or not positive (semi-)definite."""


class ParameterError(PfcourseError, ValueError):
    """A scalar parameter is outside its allowed range (N < 1, threshold not in [0, 1], ...)."""


class WeightError(PfcourseError, ValueError):
    """Weights given to a resampler or a diagnostic are negative, NaN or do not sum to one."""


class StepError(PfcourseError):
    """An error that happened at a known time step of a filter run.

    Attributes
    ----------
    step:
        Time index at which it happened (None outside a filter run).
    """

    def __init__(self, message: str, step: int | None = None) -> None:
        super().__init__(message)
        self.step = step


class DegenerateWeightsError(StepError, FloatingPointError):
    """Every particle has zero likelihood: the weights cannot be normalised."""


class NumericalError(StepError, FloatingPointError):
    """A model returned NaN (or +inf) where a number was needed."""


class ModelError(StepError, TypeError):
    """A model (or proposal, resampler, jitter) is malformed or returned something that is not
    a real array of the right kind (None, complex, object, a missing method).

    A configuration error or a bug, not a collapse: a study stops on it instead of recording a
    failed run (:func:`is_collapse`).
    """


def is_collapse(exc: BaseException) -> bool:
    """Whether ``exc`` is a run that collapsed (recorded as a failed run) rather than a bug.

    A :class:`StepError` is a collapse (every particle impossible, a NaN), except a
    :class:`ModelError`: a malformed model, proposal, collector or settings record is refused
    (at construction or at the step that meets it) and stops the study.
    """
    return isinstance(exc, StepError) and not isinstance(exc, ModelError)


class MeasurementError(PfcourseError, ValueError):
    """Measurements given to a filter are malformed (inconsistent shapes, complex, infinite)."""


class OffMapError(PfcourseError, ValueError):
    """A point lies outside a terrain map, where no height is known."""
