"""pfcourse: the helper package of the particle-filtering course book.

The notebooks teach; the plumbing lives here.  Main entry points:

* :class:`pfcourse.filter.ParticleFilter` - SIS / SIR with log-domain weights (its inner
  loops compiled with numba in :mod:`pfcourse.kernels`);
* :mod:`pfcourse.resampling` - multinomial, stratified, systematic, residual;
* :mod:`pfcourse.diagnostics` - ESS, weighted moments, NEES, ellipses;
* :mod:`pfcourse.landmarks`, :mod:`pfcourse.robot`, :mod:`pfcourse.terrain` - the three scenarios;
* :mod:`pfcourse.experiments` - Monte Carlo studies (any executor) and comparisons;
* :func:`pfcourse.landmarks.kalman.kalman_filter` - the exact Kalman reference (filterpy).
"""

from pfcourse.errors import (
    CovarianceError,
    DegenerateWeightsError,
    NumericalError,
    ParameterError,
    PfcourseError,
    ShapeError,
    WeightError,
)
from pfcourse.filter import (
    DensityProposal,
    FilterResult,
    ParticleFilter,
    StateSpaceModel,
    TransitionProposal,
)
from pfcourse.landmarks.kalman import KalmanResult, kalman_filter
from pfcourse.landmarks.model import LinearGaussianModel, OptimalProposal

__version__ = "0.2.0"

__all__ = [
    "CovarianceError",
    "DegenerateWeightsError",
    "DensityProposal",
    "FilterResult",
    "KalmanResult",
    "LinearGaussianModel",
    "NumericalError",
    "OptimalProposal",
    "ParameterError",
    "ParticleFilter",
    "PfcourseError",
    "ShapeError",
    "StateSpaceModel",
    "TransitionProposal",
    "WeightError",
    "kalman_filter",
]
