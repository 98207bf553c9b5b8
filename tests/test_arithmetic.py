"""One arithmetic on every x86-64 CPU (pfcourse/arithmetic.py, issue 13).

The stored notebook outputs are the floats of NumPy's AVX2 code paths and OpenBLAS's Haswell
kernels. These tests fail when that pinning is lost anywhere the book computes: in this pytest
process, in the notebook kernels nbval starts, in what `tasks.py` starts, or in a session that
imports pfcourse first.

Each test that compares floats across environments varies one thing and holds the rest
pinned, so that it means the same on an AVX2 and on an AVX-512 CPU (issue 27: an "other BLAS"
environment built from the unpinned one changed NumPy's `exp` too on AVX-512). Because the
machine at hand may lack AVX-512, the module also runs itself under a simulated AVX-512 CPU
(tools/simulated_avx512) and must pass there too.
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg

from pfcourse import arithmetic

ROOT = Path(__file__).resolve().parents[1]
PINNED = arithmetic.PINNED_ENVIRONMENT
reproducing = pytest.mark.skipif(
    not arithmetic.reproduces_stored_outputs(),
    reason="this platform does not reproduce the stored floats (only Linux x86-64 with AVX2 does)",
)
HAS_AVX512 = "avx512f" in arithmetic._cpu_flags()

# Digests of floats computed with the pinned code paths (NumPy 2.4.6 with its bundled OpenBLAS
# 0.3.x, glibc 2.36, on an AVX2 AMD EPYC; the same as the floats the stored notebooks were made
# with). On an AVX-512 CPU without the pinning, exp/log/sin/cos and the BLAS products differ.
# If a pinned library version changes these, every stored notebook must be regenerated too.
GOLDEN = {
    "exp": "106592c8d40fe4bd277b",
    "log": "c3f3f23d73b399772b98",
    "sin": "58f9a334fe9cd3657904",
    "cos": "85a0e8ea2ad9f3f2947e",
    "arctan2": "9341a78ca584e70abd54",
    "matmul": "0cc3bf435388399ce4f6",
    "cholesky": "ff1d49700b8d3c04f092",
    "solve": "c88eb92c65495abbc0ac",
    "scipy_cho_solve": "ab88cb50c6dcd9b106e8",
}

DIGESTS = """
import hashlib, json
import numpy as np, scipy.linalg

def h(a):
    return hashlib.sha256(np.ascontiguousarray(a).tobytes()).hexdigest()[:20]

x = np.random.default_rng(20261122).uniform(-20, 20, 100_000)
r = np.random.default_rng(7)
A, B = r.normal(size=(64, 64)), r.normal(size=(64, 3))
S = A @ A.T + 64 * np.eye(64)
print(json.dumps({
    "exp": h(np.exp(x)), "log": h(np.log(np.abs(x) + 1e-3)), "sin": h(np.sin(x)), "cos": h(np.cos(x)),
    "arctan2": h(np.arctan2(x, x[::-1])), "matmul": h(A @ A), "cholesky": h(np.linalg.cholesky(S)),
    "solve": h(np.linalg.solve(S, B)), "scipy_cho_solve": h(scipy.linalg.cho_solve(scipy.linalg.cho_factor(S), B)),
}))
"""


SIMULATED_AVX512 = ROOT / "tools" / "simulated_avx512"


def unpinned_environment(**extra: str) -> dict:
    """This process's environment with the CPU's own choices: what a new user's shell has."""
    env = {k: v for k, v in os.environ.items() if k not in PINNED}
    env.update(extra)
    return env


def pinned_environment(**extra: str) -> dict:
    """The pinned environment with only ``extra`` changed: one thing varied, the rest held."""
    env = arithmetic.pin_environment(unpinned_environment())
    env.update(extra)
    return env


def on_simulated_avx512(env: dict) -> dict:
    """``env`` on an imitated AVX-512 CPU (tools/simulated_avx512/sitecustomize.py)."""
    paths = [str(SIMULATED_AVX512), *filter(None, [env.get("PYTHONPATH")])]
    return dict(env, PYTHONPATH=os.pathsep.join(paths))


def run_python(code: str, env: dict) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", code], env=env, cwd=ROOT, capture_output=True, text=True,
                          timeout=120, check=True)


def digests(env: dict) -> dict:
    import json

    return json.loads(run_python(DIGESTS, env).stdout)


@reproducing
def test_this_process_computes_with_the_pinned_code_paths():
    for name, value in PINNED.items():
        assert os.environ.get(name) == value, f"{name} is not pinned in the test process"
    state = arithmetic.runtime_arithmetic()
    assert not state.uses_avx512, state
    assert set(state.blas_cores.values()) == {arithmetic.OPENBLAS_CORE}, state
    assert len(state.blas_cores) == 2  # NumPy's and SciPy's OpenBLAS both found and both pinned
    assert state.is_pinned


@reproducing
def test_the_pinned_floats_are_the_ones_the_book_was_computed_with():
    assert digests(os.environ.copy()) == GOLDEN


@reproducing
def test_notebook_kernels_inherit_the_pinning():
    """nbval and `tasks.py notebooks` start IPython kernels with this process's environment."""
    from jupyter_client.manager import start_new_kernel

    manager, client = start_new_kernel(kernel_name="python3", cwd=str(ROOT / "book"))
    outputs = []
    try:
        client.execute_interactive(
            "import os, numpy\nfrom pfcourse import arithmetic\n"
            "print(arithmetic.runtime_arithmetic().is_pinned, os.environ.get('OPENBLAS_CORETYPE'))",
            timeout=60,
            output_hook=lambda msg: outputs.append(msg["content"].get("text", "")),
        )
    finally:
        client.stop_channels()
        manager.shutdown_kernel(now=True)
    assert "".join(outputs).split() == ["True", arithmetic.OPENBLAS_CORE]


@reproducing
def test_tasks_py_pins_everything_it_starts():
    code = "import os, tasks; print(os.environ['NPY_DISABLE_CPU_FEATURES'] + '|' + os.environ['OPENBLAS_CORETYPE'])"
    out = run_python(code, unpinned_environment()).stdout.strip()
    assert out == "|".join(PINNED[k] for k in ("NPY_DISABLE_CPU_FEATURES", "OPENBLAS_CORETYPE"))


@reproducing
def test_importing_pfcourse_before_numpy_pins_the_session():
    code = "import pfcourse, numpy\nprint(pfcourse.arithmetic.runtime_arithmetic().is_pinned)"
    result = run_python(code, unpinned_environment())
    assert result.stdout.strip() == "True"
    assert "ReproducibilityWarning" not in result.stderr


@reproducing
def test_numpy_started_with_other_code_paths_gets_one_plain_warning():
    # OpenBLAS's Sandybridge kernels stand for another CPU's (e.g. SkylakeX on AVX-512).
    code = ("import numpy, pfcourse\nfrom pfcourse import arithmetic\n"
            "arithmetic.check()\nprint(arithmetic.runtime_arithmetic().is_pinned)")
    result = run_python(code, pinned_environment(OPENBLAS_CORETYPE="Sandybridge"))
    assert result.stdout.strip() == "False"
    assert result.stderr.count("ReproducibilityWarning") == 1
    assert "python3 tasks.py lab" in result.stderr and "last digits" in result.stderr


@reproducing
def test_other_blas_kernels_give_other_floats():
    """The pinning is not idle: another kernel family changes the BLAS results on this machine,
    and only them (NumPy's code paths stay pinned, so its `exp` is the book's on any CPU)."""
    other = digests(pinned_environment(OPENBLAS_CORETYPE="Sandybridge"))
    assert other["matmul"] != GOLDEN["matmul"] and other["exp"] == GOLDEN["exp"]


@pytest.mark.skipif(not HAS_AVX512, reason="needs a CPU with AVX-512 to compare its default code paths")
def test_on_avx512_the_default_differs_and_the_pinning_restores_the_book_floats():
    default = digests(unpinned_environment())
    assert default["exp"] != GOLDEN["exp"]  # NumPy's AVX-512 exp: the cause of issue 13
    assert digests(pinned_environment()) == GOLDEN


@reproducing
def test_the_simulated_avx512_cpu_moves_the_floats_a_real_one_moves():
    """The imitation is faithful where it matters: unpinned, NumPy's `exp` and the BLAS products
    leave the book's floats; pinned, every digest is the book's again. And it catches issue 27:
    the old "other BLAS" environment (the unpinned one, kernels changed) changes `exp` there."""
    unpinned = digests(on_simulated_avx512(unpinned_environment()))
    assert unpinned["exp"] != GOLDEN["exp"] and unpinned["matmul"] != GOLDEN["matmul"]
    assert digests(on_simulated_avx512(pinned_environment())) == GOLDEN
    issue_27 = digests(on_simulated_avx512(unpinned_environment(OPENBLAS_CORETYPE="Sandybridge")))
    assert issue_27["exp"] != GOLDEN["exp"]


@reproducing
def test_this_module_passes_on_a_simulated_avx512_cpu():
    """Every other test of this module, in a pytest run on the imitated AVX-512 CPU, the
    AVX-512-only test included (it is skipped on an AVX2 machine otherwise)."""
    result = subprocess.run(
        [sys.executable, "-m", "pytest", __file__, "-v", "-p", "no:cacheprovider", "-k", "not simulated"],
        env=on_simulated_avx512(os.environ.copy()), cwd=ROOT, capture_output=True, text=True, timeout=600,
    )
    assert result.returncode == 0, result.stdout[-4000:] + result.stderr[-2000:]
    ran = {line.split("::")[1].split()[0] for line in result.stdout.splitlines() if " PASSED" in line}
    assert "test_on_avx512_the_default_differs_and_the_pinning_restores_the_book_floats" in ran
    assert "test_other_blas_kernels_give_other_floats" in ran and "SKIPPED" not in result.stdout


def test_other_platforms_run_the_notebooks_without_comparing_floats(monkeypatch):
    spec = importlib.util.spec_from_file_location("tasks_under_test", ROOT / "tasks.py")
    tasks = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(tasks)
    calls = []
    monkeypatch.setattr(tasks, "run", lambda *cmd, **kw: calls.append([str(c) for c in cmd]))
    for reproduces, mode in ((True, "--nbval"), (False, "--nbval-lax")):
        monkeypatch.setattr(tasks.ARITHMETIC, "reproduces_stored_outputs", lambda r=reproduces: r)
        tasks.test(["tests/x.py"])
        assert calls[-1][3] == mode and calls[-1][-1] == "tests/x.py"


def test_pinning_is_a_no_op_where_floats_cannot_be_reproduced(monkeypatch):
    monkeypatch.setattr(arithmetic, "reproduces_stored_outputs", lambda: False)
    assert arithmetic.pin_environment({}) == {}
    assert arithmetic.check() is None
