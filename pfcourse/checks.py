"""Input checks shared by the package: shapes, covariances, scalar ranges.

Each check raises a named exception from :mod:`pfcourse.errors` whose message
names the offending argument, so that a student's typo surfaces as
``CovarianceError: Qw is not symmetric`` instead of a NaN ten steps later.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager
from functools import lru_cache

import numpy as np

from pfcourse import kernels
from pfcourse.errors import (
    CovarianceError,
    MeasurementError,
    ModelError,
    NumericalError,
    ParameterError,
    PfcourseError,
    ShapeError,
)

#: The array type of every signature in the package (one alias, imported from here).
Array = np.ndarray


def _real_array(value, refusal: str) -> np.ndarray:
    """``value`` as a float array; complex entries (whose imaginary part NumPy would drop), ``None``
    (which NumPy would make NaN), strings and other objects raise ``ShapeError(refusal)``."""
    try:
        raw = np.asarray(value)
        if raw.dtype.kind not in "biuf" and not (raw.dtype.kind == "O" and all(
                isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, (bool, np.bool_))
                for v in raw.reshape(-1))):
            raise TypeError
        return raw.astype(float, copy=False)
    except (TypeError, ValueError):
        raise ShapeError(f"{refusal}, got {value!r:.200}") from None


def as_vector(value, name: str, size: int | None = None, *, finite: bool = False) -> np.ndarray:
    """Return ``value`` as a 1-D float array, checking its length if ``size`` is given and,
    with ``finite=True``, that every entry is a finite number."""
    arr = _real_array(value, f"{name} must be a 1-D vector of real numbers")
    if arr.ndim != 1:
        raise ShapeError(f"{name} must be a 1-D vector, got an array of shape {arr.shape}")
    if size is not None and arr.shape[0] != size:
        raise ShapeError(f"{name} must have length {size}, got {arr.shape[0]}")
    if finite:
        check_finite(arr, name)
    return arr


def as_matrix(value, name: str, shape: tuple[int, int] | None = None, *, finite: bool = False) -> np.ndarray:
    """Return ``value`` as a 2-D float array, checking its shape if ``shape`` is given and,
    with ``finite=True``, that every entry is a finite number."""
    arr = _real_array(value, f"{name} must be a 2-D matrix of real numbers")
    if arr.ndim != 2:
        raise ShapeError(f"{name} must be a 2-D matrix, got an array of shape {arr.shape}")
    if shape is not None and arr.shape != tuple(shape):
        raise ShapeError(f"{name} must have shape {tuple(shape)}, got {arr.shape}")
    if finite:
        check_finite(arr, name)
    return arr


def as_points(value, name: str, width: int) -> np.ndarray:
    """Return ``value`` as a float array of shape ``(..., width)`` (rows of ``width`` numbers, or
    one row), refusing other dtypes, a 0-d value and another last dimension (``ShapeError``)."""
    arr = _real_array(value, f"{name} must be an array of real numbers of shape (..., {width})")
    if arr.ndim == 0 or arr.shape[-1] != width:
        raise ShapeError(f"{name} must have shape (..., {width}) ({width} numbers per row), got {arr.shape}")
    return arr


def set_checked(obj, **values) -> None:
    """Store the checked (converted) ``values`` on a frozen dataclass ``obj``, so that its fields hold
    what the checks accepted: a float, an ``int`` count, a float array (the same object when it
    already was one)."""
    for name, value in values.items():
        object.__setattr__(obj, name, value)


def check_finite(arr: np.ndarray, name: str) -> None:
    """Refuse an array with a NaN or infinite entry: ``ParameterError`` naming ``name`` and the
    first bad entry's position."""
    bad = ~np.isfinite(arr)
    if bad.any():
        where = tuple(int(i) for i in np.argwhere(bad)[0])
        raise ParameterError(
            f"{name} must be finite (real numbers, no NaN or +/-inf), got {arr[where]} at index "
            f"{where if len(where) != 1 else where[0]}"
        )


def check_covariance(
    value, name: str, size: int | None = None, *, definite: bool = False
) -> np.ndarray:
    """Check that ``value`` is a symmetric positive semi-definite matrix and return it.

    A covariance ``P`` must satisfy ``P = P^T`` and ``v^T P v >= 0`` for every
    ``v`` (all eigenvalues non-negative); with ``definite=True`` the smallest
    eigenvalue must be strictly positive (``P`` invertible).  Round-off is
    tolerated at ``1e-10`` relative to the largest entry.
    """
    arr = as_matrix(value, name)
    if arr.shape[0] != arr.shape[1]:
        raise CovarianceError(f"{name} must be square, got shape {arr.shape}")
    if arr.shape[0] == 0:
        raise ShapeError(f"{name} must be at least 1 x 1, got an empty matrix")
    if size is not None and arr.shape[0] != size:
        raise ShapeError(f"{name} must have shape ({size}, {size}), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise CovarianceError(f"{name} contains NaN or infinite entries")
    scale = max(float(np.max(np.abs(arr))), np.finfo(float).tiny)
    if not np.allclose(arr, arr.T, rtol=0.0, atol=1e-10 * scale):
        worst = float(np.max(np.abs(arr - arr.T)))
        raise CovarianceError(f"{name} is not symmetric (largest |P - P^T| = {worst:.3g})")
    smallest = float(np.linalg.eigvalsh(arr)[0])
    if definite and smallest <= 0.0:
        raise CovarianceError(
            f"{name} is not positive definite (smallest eigenvalue {smallest:.3g})"
        )
    if smallest < -1e-10 * scale:
        raise CovarianceError(
            f"{name} is not positive semi-definite (smallest eigenvalue {smallest:.3g})"
        )
    return arr


def covariance_factor(cov: np.ndarray) -> np.ndarray:
    """Return ``L`` with ``L L^T = cov``, for sampling ``x = m + L e``, ``e ~ N(0, I)``.

    Uses the Cholesky factor when ``cov`` is positive definite and falls back on
    the symmetric square root ``V diag(sqrt(max(lambda, 0))) V^T`` when it is only
    semi-definite (a state with no process noise, say).
    """
    try:
        return np.linalg.cholesky(cov)
    except np.linalg.LinAlgError:
        eigval, eigvec = np.linalg.eigh(cov)
        return eigvec * np.sqrt(np.clip(eigval, 0.0, None))


def is_missing(z: Array | None) -> bool:
    """``True`` when the measurement is absent: ``None`` or every entry NaN."""
    if z is None:
        return True
    z = np.asarray(z, dtype=float)
    return bool(z.size == 0 or np.all(np.isnan(z)))


def check_probability(value: float, name: str) -> float:
    """Check that ``value`` lies in the closed interval [0, 1]."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ParameterError(f"{name} must be a real number in [0, 1], got {value!r}")
    value = as_float(value)
    if not 0.0 <= value <= 1.0:  # also refuses NaN
        raise ParameterError(f"{name} must lie in [0, 1], got {value}")
    return value


def as_float(value) -> float:
    """``float(value)``; an integer beyond the float range is infinite (not an ``OverflowError``)."""
    try:
        return float(value)
    except OverflowError:
        return float(np.sign(value)) * np.inf


def check_real(value, name: str, *, low: float = -np.inf, high: float = np.inf,
               low_open: bool = False) -> float:
    """Check that ``value`` is a finite real number (not a bool) in ``[low, high]``
    (``(low, high]`` with ``low_open``) and return it as a float."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ParameterError(f"{name} must be a real number, got {value!r}")
    value = as_float(value)
    if not np.isfinite(value):
        raise ParameterError(f"{name} must be finite, got {value}")
    if value < low or value > high or (low_open and value == low):
        bracket = "(" if low_open else "["
        raise ParameterError(f"{name} must lie in {bracket}{low}, {high}], got {value}")
    return value


def as_generator(rng, name: str = "rng") -> np.random.Generator:
    """``numpy.random.default_rng(rng)`` for a Generator or a non-negative integer seed (or a
    sequence of them); anything else (a bool, a float, a string) is refused, and so is ``None``:
    every draw in pfcourse is seeded, so the caller must say which stream to use."""
    if isinstance(rng, np.random.Generator):
        return rng  # what default_rng returns for a Generator, without the call
    if rng is None:
        raise ParameterError(
            f"{name} must be given: pass a numpy Generator or an integer seed such as {name}=0 "
            "(every random draw is seeded, so that a run can be repeated)"
        )
    if isinstance(rng, (bool, np.bool_)):
        raise ParameterError(f"{name} must be a numpy Generator or an integer seed, got {rng!r}")
    try:
        return np.random.default_rng(rng)
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"{name} must be a numpy Generator or an integer seed, got {rng!r} ({exc})") from None


def check_interval(value, name: str) -> tuple[float, float] | None:
    """Check that ``value`` is ``None`` or a pair ``(start, stop)`` of real numbers with
    ``start <= stop`` (either may be infinite, neither NaN); return it as a pair of floats."""
    if value is None:
        return None
    try:
        pair = _real_array(value, name)
    except ShapeError:
        pair = None
    if pair is None or pair.shape != (2,) or not pair[0] <= pair[1]:
        raise ParameterError(f"{name} must be (start, stop) with start <= stop, got {value!r}")
    return float(pair[0]), float(pair[1])


def check_seed(value, name: str = "seed") -> int:
    """Return ``value`` as an ``int`` if it is a non-negative integer (a NumPy integer too; unlike
    :func:`check_count`, a float such as ``3.0`` is refused: a seed is never computed)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise ParameterError(f"{name} must be a non-negative integer, got {value!r}")
    if value < 0:
        raise ParameterError(f"{name} must be a non-negative integer, got {value}")
    return int(value)


def check_count(value: int, name: str, minimum: int = 1) -> int:
    """Check that ``value`` is an integer at least ``minimum`` (a float is accepted when it is
    integral, ``5.0``; a bool, a string or ``2.5`` is refused, whatever its size)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ParameterError(f"{name} must be an integer, got {value!r}")
    if isinstance(value, (float, np.floating)) and (not np.isfinite(value) or int(value) != value):
        raise ParameterError(f"{name} must be an integer, got {value!r}")
    if value < minimum:
        raise ParameterError(f"{name} must be at least {minimum}, got {value}")
    return int(value)


@lru_cache(maxsize=1)
def machine_memory() -> int:
    """The machine's physical memory in bytes (``2**40`` if the system does not say)."""
    try:
        return int(os.sysconf("SC_PAGE_SIZE")) * int(os.sysconf("SC_PHYS_PAGES"))
    except (AttributeError, OSError, ValueError):
        return 2**40


def check_fits(count: int, name: str, nbytes: int, what: str) -> int:
    """Refuse a count whose arrays cannot fit in this machine's memory: ``nbytes`` (the bytes
    ``what`` take for this ``count``) must not exceed :func:`machine_memory`; returns ``count``."""
    memory = machine_memory()
    if nbytes > memory:
        raise ParameterError(
            f"{name}={_magnitude(count)} is too large for this machine: {what} alone would take "
            f"{_magnitude(nbytes)} bytes and it has {memory:.3g}; pass a smaller {name}"
        )
    return count


def _magnitude(n: int) -> str:
    """A large integer for a message: ``1.23e+15``, or ``10^400`` beyond a float's range."""
    return f"{n:.3g}" if n < 10**300 else f"10^{len(str(n)) - 1}"


def check_moments(particles: np.ndarray, cov: np.ndarray, linear: np.ndarray | None = None,
                  step: int | None = None) -> None:
    """Refuse a weighted covariance of finite particles that overflowed to inf (or NaN).

    ``(x - m)^2`` overflows once the particles spread over about ``1e154``; the variances of
    the components ``linear`` (a boolean mask, all of them if ``None``; an angle's may be NaN
    when its circular mean is undefined) must then be finite, or a
    :class:`~pfcourse.errors.NumericalError` names the step and the particles' magnitude.
    """
    variances = cov.diagonal() if linear is None else cov.diagonal()[linear]
    if not np.isfinite(variances).all():
        where = "" if step is None else f"step {step}: "
        if not np.isfinite(particles).all():
            raise NumericalError(f"{where}the particles contain NaN or infinite states", step=step)
        raise NumericalError(
            f"{where}the weighted covariance of the particles overflows to inf or NaN (particle states "
            f"up to {float(np.max(np.abs(particles))):.3g} in magnitude); rescale the state",
            step=step,
        )


def check_estimate(k: int, name: str, *arrays) -> None:
    """Refuse a Kalman-type filter's output at step ``k`` (mean, covariance, log-likelihood
    increment...) with a NaN or infinite entry: an overflow, never returned silently."""
    if not all(np.isfinite(a).all() for a in arrays):
        raise NumericalError(
            f"step {k}: the {name} produced NaN or infinite values (an overflow; rescale the model "
            "or the measurements)",
            step=k,
        )


def check_simulated(name: str, values: np.ndarray, *, missing: bool = False) -> None:
    """Refuse a simulated series (one row per step) that overflowed to inf or NaN (NaN is allowed
    with ``missing=True``: a step without a measurement): a ``NumericalError`` naming the first step."""
    rows = values.reshape(len(values), -1)
    bad = np.isinf(rows) if missing else ~np.isfinite(rows)
    if bad.any():
        k = int(np.flatnonzero(bad.any(axis=1))[0])
        raise NumericalError(
            f"step {k}: the simulated {name} overflow to inf or NaN; rescale the scenario (its speeds, "
            "times, positions or noise)",
            step=k,
        )


@contextmanager
def numerical_step(k: int, name: str) -> Iterator[None]:
    """Run step ``k`` of a Kalman-type filter (through filterpy, SciPy) so that a failure on
    overflowing or non-finite numbers (a singular ``S``, a Cholesky factor of an infinite ``P``)
    is a :class:`~pfcourse.errors.NumericalError` naming the step; pfcourse's own errors pass."""
    try:
        yield
    except PfcourseError:
        raise
    except (ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:
        raise NumericalError(
            f"step {k}: the {name} failed on overflowing or non-finite numbers ({exc}); rescale the model "
            "or the measurements",
            step=k,
        ) from None


def check_measurements(measurements):
    """Check a filter's measurements once, before the run: a sequence (or array) of real arrays of
    one shape, one per step; ``None``, an empty array or all-NaN entries are missing steps
    (:func:`is_missing`), NaN entries are unobserved components, ``+/-inf`` is refused, and so is
    an empty series.  A series of scalars (an array of shape ``(K,)``, a list of floats) is a
    scalar measurement per step: it is returned as ``(K, 1)`` (a list of ``(1,)`` arrays).
    Returns them (a list if they were an array of objects)."""
    if isinstance(measurements, (str, bytes)) or not hasattr(measurements, "__len__") \
            or not hasattr(measurements, "__getitem__"):
        raise MeasurementError(
            f"measurements must be a sequence or an array (one entry per step), got {type(measurements).__name__}"
        )
    if isinstance(measurements, np.ndarray) and measurements.ndim == 0:
        raise MeasurementError("measurements must have one entry per step, got a 0-d array")
    if len(measurements) == 0:
        raise MeasurementError(
            "measurements is empty: pass one measurement per step, e.g. an array of shape (K, dim_z) "
            "with K >= 1 (None or NaN at the steps without one)"
        )
    if isinstance(measurements, np.ndarray):
        if measurements.dtype.kind not in "fiu":
            measurements = list(measurements)
        else:
            if np.isinf(measurements).any():
                raise MeasurementError("measurements contain +/-inf (use NaN for a missing value)")
            return measurements[:, None] if measurements.ndim == 1 else measurements
    shape, entries = None, []
    for k, z in enumerate(measurements):
        if z is None:
            entries.append(None)
            continue
        try:
            arr = np.asarray(z)
        except (TypeError, ValueError):  # a ragged nested list
            arr = np.empty(0, dtype=object)
        if arr.dtype.kind not in "fiu" or arr.dtype == bool:
            raise MeasurementError(
                f"step {k}: the measurement must be a real array, got dtype {arr.dtype} ({z!r:.60})"
            )
        if np.isinf(arr).any():
            raise MeasurementError(f"step {k}: the measurement contains +/-inf (use NaN for a missing value)")
        entries.append(arr.reshape(1) if arr.ndim == 0 else z)  # a scalar is a measurement of one component
        if arr.size == 0 or np.isnan(arr.astype(float)).all():
            continue
        if shape is None:
            shape = arr.shape or (1,)
        elif (arr.shape or (1,)) != shape:
            raise MeasurementError(
                f"step {k}: the measurement has shape {arr.shape or (1,)}, earlier ones have {shape}"
            )
    if any(e is not z for e, z in zip(entries, measurements)):
        return entries
    return measurements


def check_particles(particles: Array, expected: tuple[int, int], k: int, source: str) -> Array:
    """Check a cloud that ``source`` returned at step ``k`` before anything else sees it: a real
    array (``ModelError`` otherwise) of shape ``expected`` (``ShapeError``) with finite states
    (``NumericalError``); returns it as floats."""
    raw = np.asarray(particles) if particles is not None else None
    if raw is None or raw.dtype.kind not in "fiu" or raw.dtype == bool:
        kind = "None" if raw is None else f"dtype {raw.dtype}"
        raise ModelError(f"step {k}: {source} returned {kind}, expected a real array of particles", step=k)
    particles = raw.astype(float, copy=False)
    if particles.shape != expected:
        raise ShapeError(
            f"step {k}: {source} returned particles of shape {particles.shape}, "
            f"expected {expected}"
        )
    if not kernels.finite_minimum(particles.ravel())[0]:
        raise NumericalError(
            f"step {k}: {source} produced NaN or infinite particle states", step=k
        )
    return particles


def check_log_terms(values: Array, n: int, k: int, source: str = "the log-likelihood") -> Array:
    """Check log-densities that ``source`` returned at step ``k`` (one per particle) before they are
    combined: a real array (``ModelError``) of shape ``(n,)`` (``ShapeError``); returns it as floats."""
    raw = np.asarray(values) if values is not None else None
    if raw is None or raw.dtype.kind not in "fiu" or raw.dtype == bool:
        kind = "None" if raw is None else f"dtype {raw.dtype}"
        raise ModelError(
            f"step {k}: {source} (or a proposal's log-increment) is {kind}, "
            "expected a real array (return -inf for impossible particles; a missing "
            "measurement is None or NaN in the measurements, not in the likelihood)",
            step=k,
        )
    values = raw.astype(float, copy=False)
    if values.shape != (n,):
        raise ShapeError(f"step {k}: {source} has shape {values.shape}, expected ({n},)")
    return values
