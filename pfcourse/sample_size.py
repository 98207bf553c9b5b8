"""A number of particles that follows the cloud: KLD-sampling (Fox 2003).

With a fixed ``N`` a filter pays for its widest posterior (global localization: the whole
map) at every step, also once the cloud has shrunk to a few centimetres. KLD-sampling lets
the engine draw the particles of a measurement step in batches (ancestors by multinomial
resampling of the previous weighted cloud, then the proposal) and stop as soon as

    n >= max(n_min, kld_bound(b)),

where ``b`` is the number of cells of a fixed grid (``bin_size`` per state component) that
the new particles occupy, and

    kld_bound(b) = (b - 1) / (2 eps) * (1 - 2 / (9 (b - 1)) + sqrt(2 / (9 (b - 1))) z_{1-delta})^3,

the Wilson-Hilferty form of ``chi2_{b-1, 1-delta} / (2 eps)``: with probability ``1 - delta``
the Kullback-Leibler divergence between the sample-based and the true binned posterior is
below ``eps`` (Fox 2003, eq. 12). ``n`` never exceeds the filter's ``n_particles``.

The engine (:class:`pfcourse.filter.ParticleFilter`, argument ``sample_size``) asks a policy
two things: :meth:`KLDSampling.reset` at the start of a measurement step, and
:meth:`KLDSampling.needed` after each batch (the number of particles needed so far). Any
object with those two methods and the attributes ``n_min`` and ``batch`` is a policy.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy import stats

from pfcourse.checks import Array, check_count, check_probability
from pfcourse.errors import ParameterError


def kld_bound(bins: int | Array, epsilon: float = 0.05, delta: float = 0.01) -> Array:
    """Fox (2003): particles needed for ``b`` occupied bins, ``(b-1)/(2 eps) (1 - 2/(9(b-1)) + sqrt(2/(9(b-1))) z_{1-delta})^3``.

    1 for ``b <= 1``.
    """
    b = np.asarray(bins, dtype=float)
    z = stats.norm.ppf(1.0 - delta)
    bm1 = np.maximum(b - 1.0, 1.0)
    a = 2.0 / (9.0 * bm1)
    n = bm1 / (2.0 * epsilon) * (1.0 - a + np.sqrt(a) * z) ** 3
    return np.where(b <= 1, 1.0, np.ceil(n))


def cell_codes(particles: Array, bin_size: Sequence[float]) -> Array:
    """One int64 code per grid cell of ``bin_size`` (up to 3 components, cells within +-2^20 per axis)."""
    cells = np.floor(particles / np.asarray(bin_size, dtype=float)).astype(np.int64) + (1 << 20)
    code = cells[:, 0]
    for j in range(1, cells.shape[1]):
        code = (code << 21) | cells[:, j]
    return code


class KLDSampling:
    """KLD-sampling policy: draw until ``n >= max(n_min, kld_bound(occupied bins))`` (module docstring).

    ``bin_size`` has one cell width per state component (at most 3); ``batch`` particles are
    drawn at a time (Fox draws one at a time: batches overshoot the bound by less than a batch).
    """

    def __init__(self, bin_size: Sequence[float], *, n_min: int = 100, epsilon: float = 0.05,
                 delta: float = 0.01, batch: int = 100) -> None:
        size = np.asarray(bin_size, dtype=float)
        if size.ndim != 1 or not 1 <= size.size <= 3 or not np.all(np.isfinite(size)) or np.any(size <= 0):
            raise ParameterError(f"bin_size must hold 1 to 3 positive cell widths, got {bin_size!r}")
        self.bin_size = size
        self.n_min = check_count(n_min, "n_min")
        self.batch = check_count(batch, "batch")
        self.epsilon = check_probability(epsilon, "epsilon")
        self.delta = check_probability(delta, "delta")
        if self.epsilon == 0 or not 0 < self.delta < 1:
            raise ParameterError(f"need epsilon > 0 and 0 < delta < 1, got epsilon={epsilon}, delta={delta}")
        self._codes = np.empty(0, dtype=np.int64)

    def reset(self) -> None:
        """A new measurement step: no particle drawn yet."""
        self._codes = np.empty(0, dtype=np.int64)

    def needed(self, new_particles: Array) -> int:
        """Register a batch of new particles; the number the bound asks for so far."""
        if new_particles.shape[1] != self.bin_size.size:
            raise ParameterError(f"bin_size has {self.bin_size.size} widths, the particles have "
                                 f"{new_particles.shape[1]} components")
        self._codes = np.union1d(self._codes, cell_codes(new_particles, self.bin_size))
        return int(kld_bound(len(self._codes), self.epsilon, self.delta))
