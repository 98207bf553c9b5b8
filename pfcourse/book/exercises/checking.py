"""The report every checker returns, and the helpers the checkers share (collecting a student's answer)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np


@dataclass
class CheckReport:
    """Outcome of a check: ``ok`` when ``problems`` is empty."""

    name: str
    problems: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return not self.problems

    def __str__(self) -> str:
        if self.ok:
            return f"{self.name}: every check passed"
        return f"{self.name}: {len(self.problems)} problem(s)\n" + "\n".join(f"- {p}" for p in self.problems)


def _answer(report: CheckReport, call: Callable, signature: str, what: str):
    """The student's answer ``call()``, or ``None`` after reporting, in one sentence, that the call
    raised (the student's error, reported, not raised) or returned ``None`` (``what`` to do instead)."""
    try:
        with np.errstate(all="ignore"):
            answer = call()
    except Exception as exc:  # the student's error, reported
        report.problems.append(f"calling {signature} raised {type(exc).__name__}: {exc}")
        return None
    if answer is None:
        report.problems.append(f"the function returned None: {what}")
    return answer


def _shaped(report: CheckReport, answer, shape: tuple[int, ...], what: str) -> bool:
    """Whether ``answer`` has ``shape``; if not, report it, saying ``what`` to return instead."""
    got = np.shape(answer)
    if got != shape:
        report.problems.append(f"the answer has shape {got}, not {shape}: return {what}")
    return got == shape


def _cloud_answers(report: CheckReport, calls: list[Callable], signature: str, what: str, n: int,
                   one: str) -> list[np.ndarray] | None:
    """The answers of ``calls`` (one per case), each of shape ``(n,)``; ``None`` after reporting, in one
    sentence, the first that raised, returned ``None`` (``what`` to do) or has another shape (``one``
    value per row expected)."""
    answers = []
    for call in calls:
        answer = _answer(report, call, signature, what)
        if answer is None:
            return None
        if not _shaped(report, answer, (n,), f"one {one}"):
            return None
        answers.append(np.asarray(answer, dtype=float))
    return answers


def _settled(report: CheckReport, fits: Callable[[str | None], bool], mistakes: dict[str, str]) -> bool:
    """Whether the answer ``fits`` the reference (nothing to report) or one of ``mistakes`` (reported with
    its reason); ``False`` leaves the answer to the caller's own diagnosis."""
    if fits(None):
        return True
    for mistake, why in mistakes.items():
        if fits(mistake):
            report.problems.append(f"your function computes a known mistake: {why}")
            return True
    return False


def _per_particle_answers(report: CheckReport, calls: list[Callable], n_particles: int,
                          signature: str) -> list[np.ndarray] | None:
    """:func:`_cloud_answers` for checkers whose answer is one log-likelihood per particle."""
    return _cloud_answers(report, calls, signature, "compute and return one log-likelihood per particle",
                          n_particles, "log-likelihood per particle (a row of x)")
