"""The book's machinery: style, figures, panels, narrow copies, legibility, report, exercises.

It imports the library (the core, the scenarios, the studies) and the library never imports
it, so ``import pfcourse`` needs no matplotlib."""
