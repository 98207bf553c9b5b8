"""Fixtures of the browser test: the built book served on 127.0.0.1, and Debian's chromium.

The book must have been built (`python3 tasks.py browser-test` builds it first). Playwright
drives the system chromium (/usr/bin/chromium, `apt-get install chromium`); it never
downloads a browser.
"""

from __future__ import annotations

import functools
import http.server
import os
import threading
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
HTML = Path(os.environ.get("PFCOURSE_BOOK_HTML", ROOT / "_build" / "html")).resolve()
SCREENSHOTS = ROOT / "_build" / "browser" / "screenshots"
CHROMIUM = Path(os.environ.get("PFCOURSE_CHROMIUM", "/usr/bin/chromium"))
CHROMIUM_ARGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
]


def book_pages() -> list[str]:
    """Every HTML page of the built book, relative to _build/html (assets folders excluded)."""
    if not (HTML / "index.html").exists():
        return []
    return sorted(
        path.relative_to(HTML).as_posix()
        for path in HTML.rglob("*.html")
        if not any(part.startswith(("_", ".")) for part in path.relative_to(HTML).parts)
    )


def pytest_collection_modifyitems(config, items) -> None:
    # Only the tests of the built book need it (test_jupyterlab.py runs the sources).
    if any(item.path.name == "test_book.py" for item in items) and not book_pages():
        raise pytest.UsageError(
            f"no built book in {HTML}: run `python3 tasks.py build` (or `python3 tasks.py browser-test`)"
        )


class _QuietHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, format, *args) -> None:  # noqa: A002 (signature of the base class)
        pass


@pytest.fixture(scope="session")
def base_url():
    """The built book served by a threaded HTTP server on 127.0.0.1 (a free port)."""
    handler = functools.partial(_QuietHandler, directory=str(HTML))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield f"http://127.0.0.1:{server.server_address[1]}/"
    server.shutdown()
    server.server_close()
    thread.join()


@pytest.fixture(scope="session")
def browser():
    if not CHROMIUM.exists():
        raise pytest.UsageError(
            f"{CHROMIUM} not found: `apt-get update && apt-get install -y chromium` "
            "(`python3 tasks.py browser-test` does it)"
        )
    from playwright.sync_api import sync_playwright

    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=str(CHROMIUM), args=CHROMIUM_ARGS)
        yield browser
        browser.close()
