"""Settings for every pytest run from the repository root (unit tests and notebooks).

Set here, before NumPy is imported by a test or by a notebook kernel started by nbval (which
inherits this environment):

* one OpenBLAS thread (see tasks.py);
* an IPython startup file for those kernels that warns when a figure is shown with texts
  drawn over each other (pfcourse/book/legibility.py): the warning is an output strict
  nbval does not expect, so the notebook fails; and the startup of the book's own execution
  that spares each kernel an unused import (tools/execute_notebooks.py, NO_IRI_GRAMMAR);
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


def _legibility_startup() -> None:
    """IPYTHONDIR with a startup file that installs the figure legibility check (kernels inherit it)."""
    import atexit
    import shutil
    import tempfile
    from pathlib import Path

    if os.environ.get("PFCOURSE_NO_LEGIBILITY_CHECK"):
        return
    folder = Path(tempfile.mkdtemp(prefix="pfcourse-ipython-"))
    startup = folder / "profile_default" / "startup"
    startup.mkdir(parents=True)
    (startup / "00-legibility.py").write_text(
        "from pfcourse.book.legibility import check_shown_figures\ncheck_shown_figures()\n")
    from tools.execute_notebooks import NO_IRI_GRAMMAR  # as the book's own execution (see there)

    (startup / "00-no-iri-grammar.py").write_text(NO_IRI_GRAMMAR)
    os.environ["IPYTHONDIR"] = str(folder)
    os.environ["PFCOURSE_LEGIBILITY_IPYTHONDIR"] = str(folder)  # so a test can start kernels without it
    atexit.register(shutil.rmtree, folder, ignore_errors=True)


_legibility_startup()
