"""Figures and panels shared by the chapters.

* :mod:`pfcourse.book.figures.clouds` - the animated particle cloud of every chapter;
* :mod:`pfcourse.book.figures.study` - bands of Monte Carlo studies;
* :mod:`pfcourse.book.panels` - the chapters' control panels.

Colours and matplotlib settings live in :mod:`pfcourse.book.style` (core), so that scenario figures
can use them.
"""
