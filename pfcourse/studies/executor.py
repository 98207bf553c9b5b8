"""The package's one executor loop: calls shared out to any :class:`concurrent.futures.Executor`.

:func:`run_tasks` is ``[task(*args) for args in arguments]`` with the calls handed to an
executor: by default a process pool over the machine's cores (:func:`default_executor`);
:class:`SerialExecutor` runs them in this process; a cluster's executor
(``dask.distributed.Client(...).get_executor()``) spreads them over machines.  The results come
back in the order of the calls, whatever order they finish in.

* **A stuck pool is replaced.** If no call finishes for ``stall_timeout`` seconds, or a
  worker dies (the pool is broken), the pool's workers are stopped and the unfinished calls
  run in this process, with a :class:`StudyWarning`; a call whose result depends only on its
  arguments (a seeded run) gives the result the pool would have given.

Monte Carlo studies (:func:`pfcourse.studies.study.run_study`) and the static panels'
figures (:mod:`pfcourse.book.static_panel`) use it.
"""

from __future__ import annotations

import multiprocessing
import os
import pickle
import warnings
from collections.abc import Callable, Sequence
from concurrent.futures import FIRST_COMPLETED, BrokenExecutor, Executor, Future, ProcessPoolExecutor, wait

from pfcourse.arithmetic import one_blas_thread
from pfcourse.checks import check_count, check_real
from pfcourse.errors import ParameterError

#: Seconds without any finished call after which :func:`run_tasks` takes its executor as stuck.
STALL_TIMEOUT = 600.0


class StudyWarning(UserWarning):
    """A study's executor stalled or broke; its unfinished tasks were run in this process."""


class SerialExecutor(Executor):
    """An executor that runs each task at once, in the calling process (no pool, no pickling)."""

    def submit(self, fn, /, *args, **kwargs) -> Future:
        future: Future = Future()
        try:
            future.set_result(fn(*args, **kwargs))
        except BaseException as exc:  # handed back through the future, as a pool would
            future.set_exception(exc)
        return future


def default_executor(task: Callable, *example_arguments, workers: int | None = None) -> tuple[Executor, bool]:
    """A process pool over the machine's cores (``fork``, so notebook functions need no import;
    one BLAS thread per worker, :func:`pfcourse.arithmetic.one_blas_thread`),
    or a :class:`SerialExecutor` when ``task`` (or ``example_arguments``, the arguments of one call)
    cannot be sent to another process (a lambda) or
    the machine has one core.  Returns the executor and whether the caller must shut it down.
    """
    workers = (os.cpu_count() or 1) if workers is None else check_count(workers, "workers")
    if workers < 2 or "fork" not in multiprocessing.get_all_start_methods():
        return SerialExecutor(), False
    try:
        pickle.dumps((task, example_arguments))
    except (pickle.PicklingError, AttributeError, TypeError):
        return SerialExecutor(), False
    with warnings.catch_warnings():
        # Python >= 3.12 warns that forking a multi-threaded process (a Jupyter kernel) may
        # deadlock; a pool that stalls is replaced by the calling process (run_tasks).
        warnings.simplefilter("ignore", DeprecationWarning)
        return ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("fork"),
                                   initializer=one_blas_thread), True


def run_tasks(
    task: Callable,
    arguments: Sequence[tuple],
    *,
    executor: Executor | None = None,
    stall_timeout: float | None = STALL_TIMEOUT,
    on_result: Callable[[object], None] | None = None,
    workers: int | None = None,
) -> list:
    """``[task(*args) for args in arguments]``, the calls shared out to ``executor``.

    The results come back in the order of ``arguments`` whatever order they finish in;
    ``on_result`` is called on each as it arrives.  ``executor=None`` uses
    :func:`default_executor` (a process pool of ``workers`` processes, default one per core, shut
    down at the end).  If no call finishes for
    ``stall_timeout`` seconds or the executor breaks (a worker died), the unfinished calls run in
    this process, with a :class:`StudyWarning` (a pool made here has its workers stopped
    first).  An exception raised by ``task`` itself is raised here.
    """
    if executor is not None and not isinstance(executor, Executor) and not callable(getattr(executor, "submit", None)):
        raise ParameterError(f"executor must be a concurrent.futures.Executor, got {executor!r}")
    if stall_timeout is not None:
        stall_timeout = check_real(stall_timeout, "stall_timeout", low=0.0, low_open=True)
    arguments = list(arguments)
    owned = False
    if executor is None:
        executor, owned = default_executor(task, *arguments[:1], workers=workers)
    results: dict[int, object] = {}
    try:
        futures = {executor.submit(task, *args): i for i, args in enumerate(arguments)}
        pending = set(futures)
        while pending:
            done, pending = wait(pending, timeout=stall_timeout, return_when=FIRST_COMPLETED)
            try:
                for future in done:
                    results[futures[future]] = result = future.result()
                    if on_result is not None:
                        on_result(result)
            except BrokenExecutor as exc:
                _abandon(executor, owned, pending, f"a worker of {type(executor).__name__} died ({exc})")
                break
            if not done:
                _abandon(executor, owned, pending,
                         f"no task of {type(executor).__name__} finished in {stall_timeout:g} s")
                break
    finally:
        if owned:
            executor.shutdown(wait=True, cancel_futures=True)
    for i, args in enumerate(arguments):
        if i not in results:  # left by a stalled or broken executor
            results[i] = result = task(*args)
            if on_result is not None:
                on_result(result)
    return [results[i] for i in range(len(arguments))]


def _abandon(executor: Executor, owned: bool, pending: set, reason: str) -> None:
    """Give up on ``executor``: cancel what it has not started; stop its workers if we made it."""
    warnings.warn(f"{reason}; running the {len(pending)} unfinished task(s) in this process "
                  "(the results do not depend on the executor)", StudyWarning, stacklevel=3)
    for future in pending:
        future.cancel()
    if owned:  # a process pool made by default_executor: its workers may be stuck, stop them
        for process in list((getattr(executor, "_processes", None) or {}).values()):
            process.terminate()
