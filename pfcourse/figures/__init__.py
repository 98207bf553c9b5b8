"""Figures and panels shared by the chapters.

* :mod:`pfcourse.figures.clouds` - the animated particle cloud of every chapter;
* :mod:`pfcourse.figures.study` - bands of Monte Carlo studies;
* :mod:`pfcourse.figures.widgets` - the chapters' control panels.

Colours and matplotlib settings live in :mod:`pfcourse.style` (core), so that scenario figures
can use them.
"""
