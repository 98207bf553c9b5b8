"""Sphinx extension of the book: every page works with no network and a quiet console.

Loaded through ``sphinx: local_extensions`` in ``_config.yml``.  MathJax, require.js and
the widget manager are redirected to local copies by configuration alone (``mathjax_path``,
``nb_ipywidgets_js``); two things need a hook on each page:

- ``FuncAnimation.to_jshtml()`` output links Font Awesome 4.4 from a CDN for the icons of
  its play buttons (matplotlib's template): the link is pointed at the copy the book serves
  itself (Font Awesome 4.7, the same icon names).
- sphinx-thebe, loaded by jupyter-book even with thebe off, registers its configuration
  script twice (once with filename None, once ''), so the second copy throws "Identifier
  'THEBE_JS_URL' has already been declared": each script is kept once.
"""

from __future__ import annotations

from typing import Any

#: CDN stylesheets found in notebook outputs -> the book's own copy (under the output dir).
LOCAL_COPIES = {
    "https://maxcdn.bootstrapcdn.com/font-awesome/4.4.0/css/font-awesome.min.css":
        "_static/npm/font-awesome/css/font-awesome.min.css",
}


def _localize_page(app, pagename: str, templatename: str, context: dict[str, Any], doctree) -> None:
    body = context.get("body")
    if body:
        for url, local in LOCAL_COPIES.items():
            if url in body:
                body = body.replace(url, context["pathto"](local, 1))
        context["body"] = body
    scripts = context.get("script_files")
    if scripts:
        unique: dict[tuple, Any] = {}
        for script in scripts:
            attributes = tuple(sorted(getattr(script, "attributes", {}).items()))
            key = (getattr(script, "filename", script) or None, attributes)
            unique.setdefault(key, script)
        context["script_files"] = list(unique.values())


def setup(app) -> dict[str, Any]:
    # After myst-nb's handler (priority 500), which adds the widget scripts of the page.
    app.connect("html-page-context", _localize_page, priority=900)
    return {"parallel_read_safe": True, "parallel_write_safe": True, "version": "1.0"}
