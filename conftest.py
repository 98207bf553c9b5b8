"""Settings for every pytest run from the repository root (unit tests and notebooks).

One OpenBLAS thread (see tasks.py): set before numpy is imported here or in a notebook
kernel started by nbval, which inherits this environment.
"""

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
