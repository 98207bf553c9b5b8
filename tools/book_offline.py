"""Sphinx extension of the book: every page works with no network and a quiet console.

Loaded through ``sphinx: local_extensions`` in ``_config.yml``.  MathJax, require.js and
the widget manager are redirected to local copies by configuration alone (``mathjax_path``,
``nb_ipywidgets_js``); two things need a hook on each page:

- ``FuncAnimation.to_jshtml()`` output links Font Awesome 4.4 from a CDN for the icons of
  its play buttons (matplotlib's template): the link is pointed at the copy the book serves
  itself (Font Awesome 4.7, the same icon names).
- On pages with saved widgets, the widget manager (html-manager 1.x) looks for its icon
  fonts next to the AMD module it defines, which require.js resolves against the page,
  and it typesets widget labels with the MathJax 2 API (``MathJax.Hub.Queue``, an
  uncaught TypeError under MathJax 3): a small inline script maps the module to the
  book's copy and gives MathJax 3 a ``Hub.Queue`` that calls ``MathJax.typesetPromise``.
- sphinx-thebe, loaded by jupyter-book even with thebe off, registers its configuration
  script twice (once with filename None, once ''), so the second copy throws "Identifier
  'THEBE_JS_URL' has already been declared": each script is kept once.
"""

from __future__ import annotations

import hashlib
import re
from pathlib import Path
from typing import Any

#: CDN stylesheets found in notebook outputs -> the book's own copy (under the output dir).
LOCAL_COPIES = {
    "https://maxcdn.bootstrapcdn.com/font-awesome/4.4.0/css/font-awesome.min.css":
        "_static/npm/font-awesome/css/font-awesome.min.css",
}

#: Inline script for pages with saved widgets (see the module docstring); %(dist)s is the
#: page-relative URL of the widget manager's folder.
WIDGETS_SHIM = """
/* tools/book_offline.py: the widget manager offline and under MathJax 3. */
(function () {
  require.config({paths: {"@jupyter-widgets/html-manager/dist":
    new URL("%(dist)s", document.baseURI).href.replace(/\\/$/, "")}});
  var hub = {Queue: function (command) {
    var element = command && command[2], mathjax = window.MathJax;
    if (element && mathjax && mathjax.typesetPromise) {
      (mathjax.startup && mathjax.startup.promise || Promise.resolve())
        .then(function () { return mathjax.typesetPromise([element]); });
    }
  }};
  var current = window.MathJax;
  function withHub(value) {
    if (value && typeof value === "object" && !value.Hub) { value.Hub = hub; }
    return value;
  }
  /* MathJax 3 replaces window.MathJax (the configuration) by itself when it loads. */
  Object.defineProperty(window, "MathJax", {configurable: true,
    get: function () { return current; },
    set: function (value) { current = withHub(value); }});
  withHub(current);
})();
"""
WIDGET_MANAGER = "npm/html-manager/embed-amd.js"


#: sphinx-exercise writes an unnumbered exercise titled "4.1 Title" as "Exercise (4.1 Title)"; the book
#: numbers its exercises by chapter in the title itself, so the page shows "Exercise 4.1: Title" (issue 29).
EXERCISE_TITLE = re.compile(r"Exercise \((\d+\.\d+) ([^<()]*(?:\([^<()]*\)[^<()]*)*)\)")


def _localize_page(app, pagename: str, templatename: str, context: dict[str, Any], doctree) -> None:
    body = context.get("body")
    if body:
        for url, local in LOCAL_COPIES.items():
            if url in body:
                body = body.replace(url, context["pathto"](local, 1))
        body = EXERCISE_TITLE.sub(r"Exercise \1: \2", body)
        context["body"] = body
    scripts = context.get("script_files")
    if not scripts:
        return
    # Each script once, in place (Sphinx sorts this very list by priority after this event).
    unique: dict[tuple, Any] = {}
    for script in scripts:
        attributes = tuple(sorted(getattr(script, "attributes", {}).items()))
        unique.setdefault((getattr(script, "filename", script) or None, attributes), script)
    scripts[:] = unique.values()
    # The widget shim runs after require.js and before the widget manager.
    for i, script in enumerate(scripts):
        if str(getattr(script, "filename", "") or "").endswith(WIDGET_MANAGER):
            shim = WIDGETS_SHIM % {"dist": context["pathto"]("_static/npm/html-manager/", 1)}
            scripts.insert(i, type(script)(None, priority=script.priority, body=shim))
            break


def setup(app) -> dict[str, Any]:
    # A config value that changes with this file and with the book's own static files (web/static:
    # its CSS and scripts), so that editing any of them rewrites every page and copies the static
    # files again (an incremental build with no changed page copies nothing).
    digest = hashlib.sha256(Path(__file__).read_bytes())
    for static in sorted((Path(__file__).resolve().parents[1] / "web" / "static").glob("*")):
        digest.update(static.name.encode() + static.read_bytes())
    app.add_config_value("book_offline_digest", digest.hexdigest(), "html")
    # After myst-nb's handler (priority 500), which adds the widget scripts of the page.
    app.connect("html-page-context", _localize_page, priority=900)
    return {"parallel_read_safe": True, "parallel_write_safe": True, "version": "1.0"}
