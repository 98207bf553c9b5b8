"""Imitate an AVX-512 CPU on any x86-64 machine, for the tests of the pinned arithmetic.

Python runs this file at start-up when its folder is on ``PYTHONPATH``; every process started
from such a process inherits it (subprocesses, notebook kernels, pytest). The book's floats
depend on two choices a CPU makes when the libraries load (pfcourse/arithmetic.py), and this
file makes both come out as they do on an AVX-512 CPU, unless the environment pins them:

* **NumPy.** On an AVX-512 CPU NumPy's ``exp``, ``log``, ``sin``, ... take AVX-512 code paths
  that differ from the AVX2 ones in the last bit, unless ``NPY_DISABLE_CPU_FEATURES`` names
  ``X86_V4`` when NumPy is imported. Here, a NumPy imported without that setting gets the
  last-bit perturbation of ``tasks.py knife-edge`` (tools/perturbed_arithmetic.py: the next
  float up for one input in sixteen) and reports an ``AVX512F`` dispatch target.
* **OpenBLAS.** Left to choose, it picks another kernel family than the pinned Haswell one
  (SkylakeX on AVX-512; here Sandybridge, which rounds differently too).
* **The CPU's flags.** ``pfcourse.arithmetic`` sees ``avx512f`` among them.

A test that silently relies on the machine it was written on having AVX2 only (issue 27:
an "other BLAS" environment built from the unpinned one changed NumPy's ``exp`` too) fails here
as it would on an AVX-512 machine. ``tests/test_arithmetic.py`` runs itself this way.
"""

from __future__ import annotations

import importlib.abc
import importlib.util
import os
import sys
from pathlib import Path

TOOLS = Path(__file__).resolve().parents[1]


def _numpy_pinned() -> bool:
    return "X86_V4" in os.environ.get("NPY_DISABLE_CPU_FEATURES", "").split()


def _perturb_numpy(numpy) -> None:
    """NumPy's AVX-512 transcendental functions, imitated: unless pinned when NumPy loads."""
    if _numpy_pinned():
        return
    spec = importlib.util.spec_from_file_location("_perturbed_arithmetic", TOOLS / "perturbed_arithmetic.py")
    tool = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(tool)
    exec(tool.PERTURB_FUNCTIONS, {"_np": numpy})  # noqa: S102  (our own tool's code)
    numpy._simulated_avx512 = True


def _report_avx512(arithmetic) -> None:
    """pfcourse.arithmetic sees the simulated CPU: its flags, and NumPy's AVX-512 target in use."""
    cpu_flags, runtime = arithmetic._cpu_flags, arithmetic.runtime_arithmetic

    def simulated_cpu_flags() -> set[str]:
        return cpu_flags() | {"avx512f"}

    def simulated_runtime():
        state = runtime()
        if getattr(sys.modules["numpy"], "_simulated_avx512", False):
            state = arithmetic.RuntimeArithmetic(state.numpy_simd + ("AVX512F",), state.blas_cores)
        return state

    arithmetic._cpu_flags, arithmetic.runtime_arithmetic = simulated_cpu_flags, simulated_runtime


class _AfterImport(importlib.abc.MetaPathFinder):
    """Runs ``action(module)`` right after the named modules are executed, as an import hook."""

    def __init__(self, actions: dict) -> None:
        self.actions = actions

    def find_spec(self, name, path, target=None):
        if name not in self.actions:
            return None
        for finder in sys.meta_path:
            if finder is self or not hasattr(finder, "find_spec"):
                continue
            spec = finder.find_spec(name, path, target)
            if spec is not None and spec.loader is not None:
                break
        else:
            return None
        execute, action = spec.loader.exec_module, self.actions[name]

        def exec_module(module):
            execute(module)
            action(module)

        spec.loader.exec_module = exec_module
        return spec


if not os.environ.get("OPENBLAS_CORETYPE"):
    os.environ["OPENBLAS_CORETYPE"] = "Sandybridge"  # what OpenBLAS picks unpinned (SkylakeX there)
sys.meta_path.insert(0, _AfterImport({"numpy": _perturb_numpy, "pfcourse.arithmetic": _report_avx512}))
