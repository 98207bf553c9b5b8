"""The README's example runs as a new user runs it: in a fresh Python, unpinned, on any x86-64 CPU.

It imports pfcourse before NumPy, so NumPy loads with the book's arithmetic and no
ReproducibilityWarning is printed, even on an AVX-512 CPU (imitated here by
tools/simulated_avx512, since the machine at hand may lack one).
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

from pfcourse import arithmetic
from test_arithmetic import on_simulated_avx512, unpinned_environment

ROOT = Path(__file__).resolve().parents[1]
SECTION = ROOT.joinpath("README.md").read_text().split("## Using the package", 1)[1].split("\n## ", 1)[0]
EXAMPLE = re.findall(r"```python\n(.*?)```", SECTION, flags=re.S)[0]
CHECK = "\nimport numpy\nassert numpy.isfinite(result.mean).all() and result.mean.shape == (3, 1)\nprint('ok')\n"
CPUS = {"this CPU": lambda env: env, "an imitated AVX-512 CPU": on_simulated_avx512}


def run(code: str, cpu: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", code], env=CPUS[cpu](unpinned_environment()), cwd=ROOT,
                          capture_output=True, text=True, timeout=300)


@pytest.mark.parametrize("cpu", CPUS)
def test_the_readme_example_runs_without_a_warning(cpu):
    result = run(EXAMPLE + CHECK, cpu)
    assert result.returncode == 0 and result.stdout.split() == ["ok"], result.stderr[-3000:]
    assert "Warning" not in result.stderr, result.stderr[-3000:]


@pytest.mark.skipif(not arithmetic.reproduces_stored_outputs(), reason="nothing is pinned on this platform")
def test_numpy_first_on_an_avx512_cpu_would_warn():
    """The test above can fail: the example with NumPy imported first warns on AVX-512."""
    lines = EXAMPLE.splitlines()
    first = next(i for i, line in enumerate(lines) if line.startswith("from pfcourse import"))
    numpy_first = "\n".join(["import numpy as np", lines[first], *lines[:first], *lines[first + 1:]])
    result = run(numpy_first + CHECK, "an imitated AVX-512 CPU")
    assert result.returncode == 0 and result.stderr.count("ReproducibilityWarning") == 1, result.stderr[-3000:]
