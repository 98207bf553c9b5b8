"""One floating-point arithmetic on every x86-64 CPU: the SIMD and BLAS code paths the book uses.

A seeded particle filter is a deterministic function of its random stream, but not of the CPU
it runs on. Two libraries under NumPy choose their code at run time from the CPU's features:

* NumPy dispatches ``exp``, ``log``, ``sin``, ``cos``, ... to an AVX-512 implementation on
  CPUs that have it (``X86_V4`` and later). It differs from the AVX2 path (and from the C
  library's ``exp``, which the compiled kernels call) in the last bit for about 5 % of
  inputs.
* OpenBLAS (shipped inside the NumPy and SciPy wheels) picks a kernel per CPU family
  (Haswell, Zen, SkylakeX, ...), and the kernels round sums of products differently.

A resampling decision taken on a weight that moved by one ulp can send a run elsewhere, so
the stored outputs of the book are reproduced bit for bit only when both choices are fixed.
Both libraries read their choice from the environment *when they are loaded*, so it must
be set before ``import numpy``:

    NPY_DISABLE_CPU_FEATURES="X86_V4 AVX512_ICL AVX512_SPR"   # NumPy: no AVX-512 paths
    OPENBLAS_CORETYPE=Haswell                                  # OpenBLAS: the AVX2 kernels

``python3 tasks.py`` sets them for every command (tests, notebook kernels, JupyterLab,
the benchmark), the root ``conftest.py`` for a bare ``pytest``, and :mod:`pfcourse` itself when
it is imported before NumPy. When NumPy was imported first with other settings,
:func:`check` warns once, in plain words, that results may differ in the last digits from the
book's.

This module imports only the standard library at load time (``tasks.py`` reads
:data:`PINNED_ENVIRONMENT` from it before the project's environment exists).
"""

from __future__ import annotations

import ctypes
import glob
import os
import platform
import sys
import warnings
from dataclasses import dataclass
from pathlib import Path

#: NumPy's dispatch targets that use AVX-512 (NumPy 2.x names; unknown names are ignored on
#: CPUs that lack them, and a CPU without AVX-512 is not affected at all).
NUMPY_DISABLED_FEATURES = ("X86_V4", "AVX512_ICL", "AVX512_SPR")
#: OpenBLAS kernel family used on every CPU: the AVX2 + FMA kernels, which every AVX2 and
#: AVX-512 CPU (Intel Haswell and later, AMD Zen and later) can run.
OPENBLAS_CORE = "Haswell"

PINNED_ENVIRONMENT: dict[str, str] = {
    "NPY_DISABLE_CPU_FEATURES": " ".join(NUMPY_DISABLED_FEATURES),
    "OPENBLAS_CORETYPE": OPENBLAS_CORE,
}


class ReproducibilityWarning(UserWarning):
    """This process computes with other CPU code paths than the ones the book was made with."""


def _cpu_flags() -> set[str]:
    """The CPU's feature flags as Linux reports them (empty set elsewhere)."""
    try:
        text = Path("/proc/cpuinfo").read_text()
    except OSError:
        return set()
    for line in text.splitlines():
        if line.startswith("flags"):
            return set(line.split(":", 1)[1].split())
    return set()


def reproduces_stored_outputs() -> bool:
    """True on the platforms whose floats are those of the stored notebooks.

    Linux on an x86-64 CPU with AVX2 and FMA (Intel Haswell, 2013, AMD Zen, 2017, and every
    later CPU, with or without AVX-512), once :data:`PINNED_ENVIRONMENT` is in force. Elsewhere
    (ARM, macOS, Windows, older x86-64) the libraries take other code paths (other SIMD
    instructions, another C library), and results agree with the book's only to rounding.
    """
    if sys.platform != "linux" or platform.machine().lower() not in ("x86_64", "amd64"):
        return False
    return {"avx2", "fma"} <= _cpu_flags()


def pin_environment(environ: dict | None = None) -> dict:
    """Put :data:`PINNED_ENVIRONMENT` into ``environ`` (default ``os.environ``) and return it.

    Only on the platforms of :func:`reproduces_stored_outputs`: forcing the Haswell kernels on
    a CPU without AVX2 would not run. Settings already present are overwritten, because any
    other value gives other floats than the book's.
    """
    environ = os.environ if environ is None else environ
    if reproduces_stored_outputs():
        environ.update(PINNED_ENVIRONMENT)
    return environ


@dataclass(frozen=True)
class RuntimeArithmetic:
    """What this process computes with: NumPy's active SIMD targets and the OpenBLAS kernels."""

    numpy_simd: tuple[str, ...]  # NumPy's dispatch targets in use (e.g. ('X86_V3',))
    blas_cores: dict  # OpenBLAS library file name -> kernel family it chose

    @property
    def uses_avx512(self) -> bool:
        return any(t in NUMPY_DISABLED_FEATURES or t.startswith("AVX512") for t in self.numpy_simd)

    @property
    def is_pinned(self) -> bool:
        """No AVX-512 path in NumPy, and the Haswell kernels in every OpenBLAS found."""
        return (not self.uses_avx512) and bool(self.blas_cores) and all(
            core.lower() == OPENBLAS_CORE.lower() for core in self.blas_cores.values()
        )


def _openblas_libraries() -> list[str]:
    """Paths of the OpenBLAS libraries bundled with NumPy and SciPy, for those already imported."""
    candidates = []
    for name in ("numpy", "scipy"):
        module = sys.modules.get(name)
        if module is None or module.__file__ is None:
            continue
        libs = Path(module.__file__).resolve().parent.parent / f"{name}.libs"
        candidates += sorted(glob.glob(str(libs / "*openblas*")))
    return candidates


def openblas_functions(name: str) -> list[tuple[str, object]]:
    """``(library path, function)`` for OpenBLAS function ``name`` (``"get_corename"``, ...) in
    each loaded library, under whichever of its exported names the library has (SciPy's
    wheels prefix ``scipy_`` and append ``64_`` in their ILP64 builds)."""
    found = []
    for path in _openblas_libraries():
        try:
            lib = ctypes.CDLL(path)
        except OSError:
            continue
        for symbol in (f"scipy_openblas_{name}64_", f"scipy_openblas_{name}", f"openblas_{name}64_",
                       f"openblas_{name}"):
            function = getattr(lib, symbol, None)
            if function is not None:
                found.append((path, function))
                break
    return found


def _openblas_cores() -> dict:
    """Kernel family of each OpenBLAS library bundled with NumPy and SciPy (if loaded)."""
    cores = {}
    for path, function in openblas_functions("get_corename"):
        function.restype = ctypes.c_char_p
        cores[Path(path).name] = function().decode()
    return cores


def one_blas_thread() -> int:
    """Make every loaded OpenBLAS use one thread in this process; returns how many libraries it set.

    The Monte Carlo runner and the static panels fork one worker per core. A worker
    inherits OpenBLAS's thread pool setting (one thread per core), so two workers on two
    cores run four BLAS threads that spin waiting for each other: a Part III study of small
    Kalman filters ran 15 times slower in the pool than in one process. Called as the
    pools' initializer. The floats do not change (each entry of a product is computed by
    one thread either way; ``tests/test_study.py`` compares pooled and serial tables).
    """
    functions = openblas_functions("set_num_threads")
    for _, function in functions:
        function.argtypes = [ctypes.c_int]
        function(1)
    return len(functions)


def runtime_arithmetic() -> RuntimeArithmetic:
    """Inspect NumPy's SIMD dispatch and OpenBLAS's kernels in this process (imports NumPy)."""
    import numpy  # noqa: F401  (loads NumPy's OpenBLAS)
    from numpy._core import _multiarray_umath as umath

    active = tuple(t for t in umath.__cpu_dispatch__ if umath.__cpu_features__.get(t, False))
    return RuntimeArithmetic(numpy_simd=active, blas_cores=_openblas_cores())


_checked = False


def check(stacklevel: int = 3) -> RuntimeArithmetic | None:
    """Pin the environment if NumPy is not loaded yet; otherwise warn once if it is not pinned.

    Called by ``import pfcourse``. Returns the runtime arithmetic on the platforms that
    reproduce the stored outputs, ``None`` elsewhere.
    """
    global _checked
    if not reproduces_stored_outputs():
        return None
    if "numpy" not in sys.modules:
        pin_environment()
    state = runtime_arithmetic()
    if not state.is_pinned and not _checked:
        blas = ", ".join(sorted(set(state.blas_cores.values()))) or "unknown"
        warnings.warn(
            # short on purpose: a student pasting a chapter's code sees it once; the README's
            # "One arithmetic on every x86-64 CPU" explains the rest
            "pfcourse: NumPy was imported before pfcourse, so your results (correct) may differ "
            "from the book's in the last digits. For the book's exact numbers, restart and run "
            "`import pfcourse` first, or start Jupyter with `python3 tasks.py lab`. "
            f"(SIMD: {', '.join(state.numpy_simd) or 'baseline'}; OpenBLAS kernels: {blas}; "
            "or set " + " ".join(f'{k}="{v}"' for k, v in PINNED_ENVIRONMENT.items()) + ")",
            ReproducibilityWarning,
            stacklevel=stacklevel,
        )
    _checked = True
    return state
