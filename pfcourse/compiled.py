"""The package's numba settings: every compiled loop is ``@jit``.

``cache=True`` keeps the machine code in ``__pycache__`` (only the first import on a machine
compiles, about 10 s); ``nogil=True`` lets a thread pool run the loops side by side.
"""

from __future__ import annotations

import numba

jit = numba.njit(cache=True, nogil=True)
