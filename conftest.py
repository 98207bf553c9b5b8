"""Settings for every pytest run from the repository root (unit tests and notebooks).

Set here, before NumPy is imported by a test or by a notebook kernel started by nbval (which
inherits this environment):

* one OpenBLAS thread (see tasks.py);
* one arithmetic on every x86-64 CPU (pfcourse/arithmetic.py): NumPy without its AVX-512
  code paths, OpenBLAS with its Haswell kernels, so that the stored notebook outputs and the
  bit-for-bit unit tests hold on AVX2 and AVX-512 machines alike.
"""

import os
import sys

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

if "numpy" in sys.modules:  # a pytest plugin loaded NumPy before this file: too late to pin it
    raise RuntimeError(
        "NumPy was imported before the root conftest.py could pin its CPU code paths "
        "(pfcourse/arithmetic.py); run the tests with `python3 tasks.py test`."
    )

from pfcourse import arithmetic  # noqa: E402  (stdlib only at import: pfcourse/__init__ is run
                                 # here too, and pins the environment before it imports NumPy)

arithmetic.pin_environment()
