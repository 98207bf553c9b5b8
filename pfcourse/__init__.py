"""pfcourse: the helper package of the particle-filtering course book.

The notebooks teach; the plumbing lives here.  Main entry points:

* :class:`pfcourse.filter.ParticleFilter` - SIS / SIR with log-domain weights (its inner
  loops compiled with numba in :mod:`pfcourse.kernels`);
* :mod:`pfcourse.resampling` - multinomial, stratified, systematic, residual;
* :mod:`pfcourse.diagnostics` - ESS, weighted moments, NEES, ellipses;
* :mod:`pfcourse.scenarios.landmarks`, :mod:`pfcourse.scenarios.robot`, :mod:`pfcourse.scenarios.terrain` - the three scenarios;
* :mod:`pfcourse.studies` - Monte Carlo studies (any executor) and comparisons;
* :func:`pfcourse.kalman.kalman_filter` - the exact Kalman reference, on a
  :class:`pfcourse.linear_gaussian.LinearGaussianModel`, one of the Kalman family that
  :func:`pfcourse.kalman.gaussian_filter` runs (KF, EKF, UKF);
* :mod:`pfcourse.proposals`, :mod:`pfcourse.jitter`, :mod:`pfcourse.smoothing`, :mod:`pfcourse.pmmh`
  - importance functions, moves after resampling, smoothers, particle MCMC;
* :func:`pfcourse.studies.executor.run_tasks` - the one loop that shares calls over an executor.
"""

# First, before anything loads NumPy: the CPU code paths the book's floats were computed with
# (pfcourse.arithmetic; pins them if NumPy is not loaded yet, warns once if it was, unpinned).
from pfcourse import arithmetic as _arithmetic

_arithmetic.check()

from pfcourse.errors import (  # noqa: E402
    CovarianceError,
    DegenerateWeightsError,
    ModelError,
    NumericalError,
    ParameterError,
    PfcourseError,
    ShapeError,
    WeightError,
)
from pfcourse.results import FilterResult, KalmanResult  # noqa: E402
from pfcourse.filter import ParticleFilter, StateSpaceModel, Step  # noqa: E402
from pfcourse.collectors import (  # noqa: E402
    ESS, Ancestors, Clouds, Collector, LastCloud, LogLikelihood, Moments, Resampled, Sizes, Stages,
)
from pfcourse.filter_config import FilterSettings  # noqa: E402
from pfcourse.kalman import kalman_filter  # noqa: E402
from pfcourse.linear_gaussian import LinearGaussianModel  # noqa: E402
from pfcourse.proposals import DensityProposal, OptimalProposal, TransitionProposal  # noqa: E402

__version__ = "0.4.0"

__all__ = [
    "Ancestors",
    "Clouds",
    "Collector",
    "CovarianceError",
    "DegenerateWeightsError",
    "DensityProposal",
    "ESS",
    "FilterResult",
    "FilterSettings",
    "KalmanResult",
    "LastCloud",
    "LinearGaussianModel",
    "LogLikelihood",
    "ModelError",
    "Moments",
    "NumericalError",
    "OptimalProposal",
    "ParameterError",
    "ParticleFilter",
    "PfcourseError",
    "Resampled",
    "ShapeError",
    "Sizes",
    "Stages",
    "StateSpaceModel",
    "Step",
    "TransitionProposal",
    "WeightError",
    "kalman_filter",
]
