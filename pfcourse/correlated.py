"""Correlated random numbers for the particle filter's likelihood estimate (correlated pseudo-marginal).

A particle filter's estimate ``p^(z | theta)`` is a function of ``theta`` and of the random
numbers ``U`` it draws.  Deligiannidis, Doucet and Pitt (2018) write every draw as a function of
standard normals, so ``U ~ N(0, I)``, and move ``U`` in a Metropolis-Hastings chain by a
**Crank-Nicolson** step,

.. math::

   U' = \\rho\\, U + \\sqrt{1 - \\rho^2}\\, \\varepsilon, \\qquad \\varepsilon \\sim \\mathcal N(0, I),

which leaves ``N(0, I)`` invariant (:func:`crank_nicolson`).  With ``rho`` near ``1`` the
estimates at the current and the proposed point are strongly correlated, and the noise of their
*ratio* is small.  Resampling breaks that unless it is made continuous in ``U``: the cloud is
sorted (along a **Hilbert curve** in ``d > 1`` dimensions, :func:`hilbert_order`) before systematic
resampling, so that a small change of the normals changes few ancestors.

Nothing new runs the filter: :class:`NormalStream` is a ``numpy.random.Generator`` whose
``standard_normal``, ``normal``, ``random`` and ``uniform`` read the given normals in order
(a uniform is ``Phi(u)``); :class:`SortedModel` returns every drawn cloud in Hilbert order (a
permutation of the particles, which does not change the filter's law); and
:func:`correlated_log_likelihood` runs :class:`pfcourse.filter.ParticleFilter` on them with
systematic resampling at every measured step (``threshold = 1``), so the stream is read the same
way for every ``theta``.
"""

from __future__ import annotations

import numpy as np
from scipy.special import ndtr

from pfcourse.checks import as_generator, check_count
from pfcourse.compiled import jit
from pfcourse.errors import ParameterError
from pfcourse.filter import ParticleFilter


def crank_nicolson(u: np.ndarray, rho: float, rng: np.random.Generator) -> np.ndarray:
    """``rho u + sqrt(1 - rho^2) e``, ``e ~ N(0, I)`` from ``rng``: a move that keeps ``N(0, I)``."""
    rho = float(rho)
    if not 0.0 <= rho <= 1.0:
        raise ParameterError(f"rho must be in [0, 1], got {rho}")
    rng = as_generator(rng)
    u = np.asarray(u, dtype=float)
    return rho * u + np.sqrt(1.0 - rho**2) * rng.standard_normal(u.shape)


class NormalStream(np.random.Generator):
    """A generator that reads its draws from ``normals``, in order (module docstring).

    ``standard_normal``, ``normal``, ``random`` and ``uniform`` are served (a uniform as
    ``Phi(u)``); any other draw is refused with a :class:`~pfcourse.errors.ParameterError`, and
    so is a run that asks for more normals than given.  ``used`` counts those read.
    """

    def __init__(self, normals) -> None:
        super().__init__(np.random.PCG64(0))
        self.normals = np.asarray(normals, dtype=float).ravel()
        if not np.all(np.isfinite(self.normals)):
            raise ParameterError("the normals of a NormalStream must be finite")
        self.used = 0

    def _take(self, size) -> np.ndarray | float:
        m = 1 if size is None else int(np.prod(size))
        if self.used + m > self.normals.size:
            raise ParameterError(f"the run asks for more than the {self.normals.size} normals given "
                                 f"(pfcourse.correlated.normals_needed)")
        v = self.normals[self.used:self.used + m]
        self.used += m
        return float(v[0]) if size is None else v.reshape(size)

    def standard_normal(self, size=None, dtype=np.float64, out=None):
        if out is not None or dtype not in (np.float64, float, "d"):
            raise ParameterError("NormalStream.standard_normal serves float64 draws without out=")
        return self._take(size)

    def normal(self, loc=0.0, scale=1.0, size=None):
        if size is None:
            size = np.broadcast(np.asarray(loc), np.asarray(scale)).shape or None
        return np.asarray(loc) + np.asarray(scale) * self._take(size) if size is not None \
            else float(loc) + float(scale) * self._take(None)

    def random(self, size=None, dtype=np.float64, out=None):
        if out is not None:
            raise ParameterError("NormalStream.random serves draws without out=")
        return ndtr(self._take(size))

    def uniform(self, low=0.0, high=1.0, size=None):
        return low + (high - low) * self.random(size)

    def _refuse(self, *args, **kwargs):
        raise ParameterError("a NormalStream serves standard_normal, normal, random and uniform only: the model "
                             "or resampler drew otherwise (write that draw from normals)")

    integers = choice = multinomial = multivariate_normal = permutation = shuffle = _refuse
    exponential = gamma = beta = poisson = binomial = standard_exponential = standard_gamma = _refuse


def normals_needed(dim_x: int, n_particles: int, n_steps: int) -> int:
    """Normals a bootstrap run reads: ``N d`` per step (initial draw, moves) and one per resampling."""
    return check_count(dim_x, "dim_x") * check_count(n_particles, "n_particles") * check_count(n_steps, "n_steps") \
        + n_steps


@jit
def _hilbert_keys(X: np.ndarray, bits: int) -> np.ndarray:
    """The loop of :func:`hilbert_keys` (compiled), on ``X`` ``(n, d)`` int64, changed in place."""
    n, d = X.shape
    keys = np.zeros(n, dtype=np.uint64)
    M = 1 << (bits - 1)
    for r in range(n):
        x = X[r]
        Q = M
        while Q > 1:  # undo the excess work
            P = Q - 1
            for i in range(d):
                if x[i] & Q:
                    x[0] ^= P  # invert the low bits of x_0
                else:
                    t = (x[0] ^ x[i]) & P  # exchange the low bits of x_0 and x_i
                    x[0] ^= t
                    x[i] ^= t
            Q >>= 1
        for i in range(1, d):  # Gray encode
            x[i] ^= x[i - 1]
        t = 0
        Q = M
        while Q > 1:
            if x[d - 1] & Q:
                t ^= Q - 1
            Q >>= 1
        key = 0
        for b in range(bits - 1, -1, -1):  # interleave the bits
            for i in range(d):
                key = (key << 1) | (((x[i] ^ t) >> b) & 1)
        keys[r] = key
    return keys


def hilbert_keys(cells: np.ndarray, bits: int) -> np.ndarray:
    """The index along the Hilbert curve of each row of integer ``cells`` ``(n, d)`` in ``[0, 2^bits)``.

    Skilling's transpose algorithm (2004): undo the excess work, Gray-encode, interleave the bits.
    """
    X = np.array(cells, dtype=np.int64, copy=True)
    if X.ndim != 2 or X.shape[1] * bits > 63 or bits < 1:
        raise ParameterError(f"cells must be (n, d) with 1 <= bits and d * bits <= 63, got {X.shape}, bits {bits}")
    if X.size and (X.min() < 0 or X.max() >= 2**bits):
        raise ParameterError(f"cells must lie in [0, 2^{bits})")
    return _hilbert_keys(X, int(bits))


def hilbert_order(particles: np.ndarray) -> np.ndarray:
    """The permutation that sorts ``particles`` ``(n, d)`` along a Hilbert curve.

    In one dimension the plain sort.  Otherwise each coordinate is standardised over the cloud,
    mapped into ``(0, 1)`` by the logistic function (Gerber and Chopin's choice) and cut into
    ``2^bits`` cells, ``bits = 63 // d`` capped at 16.
    """
    x = np.asarray(particles, dtype=float)
    if x.ndim != 2:
        raise ParameterError(f"particles must be (n, d), got shape {x.shape}")
    if x.shape[1] == 1:
        return np.argsort(x[:, 0], kind="stable")
    bits = min(16, 63 // x.shape[1])
    sd = x.std(axis=0)
    y = (x - x.mean(axis=0)) / np.where(sd > 0, sd, 1.0)
    cells = np.minimum(np.floor(1.0 / (1.0 + np.exp(-y)) * 2**bits), 2**bits - 1).astype(np.int64)
    return np.argsort(hilbert_keys(cells, bits), kind="stable")


class SortedModel:
    """``model`` whose drawn clouds come back in Hilbert order (:func:`hilbert_order`), so that the
    systematic resampling that follows is continuous in the normals."""

    def __init__(self, model) -> None:
        self.model = model
        self.dim_x = model.dim_x
        self.angle_indices = tuple(getattr(model, "angle_indices", ()))

    def sample_initial(self, n, rng):
        x = self.model.sample_initial(n, rng)
        return x[hilbert_order(x)]

    def sample_transition(self, particles, k, rng):
        x = self.model.sample_transition(particles, k, rng)
        return x[hilbert_order(x)]

    def log_likelihood(self, particles, z, k):
        return self.model.log_likelihood(particles, z, k)


def correlated_log_likelihood(model, measurements, n_particles: int, normals, sort: bool = True) -> float:
    """``log p^(z)`` of the bootstrap filter drawing from ``normals`` (module docstring).

    ``sort=False`` keeps the drawn order (resampling then jumps when the normals move).
    """
    run_model = SortedModel(model) if sort else model
    pf = ParticleFilter(run_model, n_particles, threshold=1.0, resampler="systematic")
    return pf.run(measurements, NormalStream(normals)).log_likelihood
