"""The live path: every chapter that has a control panel, run in JupyterLab, answers its controls.

The test starts JupyterLab itself on 127.0.0.1 (a free port, a random token, no browser, every
request from the page outside 127.0.0.1 blocked) on a temporary copy of book/ (running the
cells must not rewrite the stored notebooks: JupyterLab autosaves), and for each chapter whose
source calls ``control_panel``:

- opens the notebook, runs all cells and waits until the kernel is idle with every code cell
  executed;
- requires no error output in any cell (no ``jp-RenderedText[data-mime-type=application/
  vnd.jupyter.stderr]`` traceback, no error output) and no console error or warning;
- moves one control of the panel (the first slider one step with the keyboard, else the first
  drop-down to its next option) and requires the panel's figure to change within 2 s.

JupyterLab renders the MyST markup with jupyterlab-myst (requirements.txt); the test also
checks that it is active: no exercise directive (``:label:`` lines) is left as raw text. A
cross-reference to another chapter (tools/lab_glue.py turns it into a markdown link) renders as a
link and, clicked, opens that chapter's notebook; no "Cross reference target was not found" is
logged.
"""

from __future__ import annotations

import json
import os
import secrets
import shutil
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from conftest import ROOT

sys.path.insert(0, str(ROOT / "tools"))
import lab_glue  # noqa: E402

BOOK = ROOT / "book"
PANEL_CHAPTERS = sorted(
    path.relative_to(BOOK).with_suffix(".ipynb").as_posix()
    for path in BOOK.glob("*/*.py")
    if "control_panel" in path.read_text(encoding="utf-8")
)
START_TIMEOUT_S = 90
RUN_TIMEOUT_MS = 240_000  # the slowest chapter with a panel executes in well under this
REDRAW_TIMEOUT_MS = 2_000
_JSHTML_ICONS = "https://maxcdn.bootstrapcdn.com/font-awesome/4.4.0/css/font-awesome.min.css"
SHOTS = ROOT / "_build" / "browser" / "jupyterlab"  # a screenshot of each chapter after its check


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


@pytest.fixture(scope="module")
def lab(tmp_path_factory):
    """JupyterLab serving a copy of book/ on 127.0.0.1; yields its base URL and token."""
    root = tmp_path_factory.mktemp("lab")
    shutil.copytree(BOOK, root / "book", ignore=shutil.ignore_patterns("_build", ".ipynb_checkpoints"))
    port, token = _free_port(), secrets.token_hex(16)
    command = [
        sys.executable, "-m", "jupyter", "lab",
        "--no-browser",
        f"--ServerApp.ip=127.0.0.1",
        f"--ServerApp.port={port}",
        "--ServerApp.port_retries=0",
        f"--IdentityProvider.token={token}",
        f"--ServerApp.root_dir={root / 'book'}",
        "--LabApp.expose_app_in_browser=True",
    ]
    # The JupyterLab a reader gets from `python3 tasks.py lab` (tools/lab_glue.py, reader_lab):
    # glued numbers shown as values, no news, --allow-root as root, no cell toolbar. Its kernels
    # do not get the legibility check the root conftest.py gives nbval's kernels (one more
    # drawing per shown figure would slow the redraw this test times).
    options, lab_env = lab_glue.reader_lab(root)
    command += options
    env = dict(os.environ, **lab_env, JUPYTER_RUNTIME_DIR=str(root / "runtime"))
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT / "tools"), env.get("PYTHONPATH")]))
    log = open(root / "lab.log", "w")  # noqa: SIM115 (closed below)
    process = subprocess.Popen(command, stdout=log, stderr=subprocess.STDOUT, env=env, cwd=root / "book")
    base = f"http://127.0.0.1:{port}"
    try:
        deadline = time.monotonic() + START_TIMEOUT_S
        while True:
            if process.poll() is not None:
                raise RuntimeError(f"JupyterLab exited ({process.returncode}): {(root / 'lab.log').read_text()[-2000:]}")
            try:
                with socket.create_connection(("127.0.0.1", port), timeout=1):
                    break
            except OSError:
                if time.monotonic() > deadline:
                    raise RuntimeError(f"JupyterLab did not listen on {port} within {START_TIMEOUT_S} s")
                time.sleep(0.5)
        yield base, token
    finally:
        process.terminate()
        try:
            process.wait(timeout=20)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()
        log.close()


def test_chapters_with_panels_found() -> None:
    """The chapter list comes from the sources (a chapter with a panel is never forgotten)."""
    assert len(PANEL_CHAPTERS) >= 5, PANEL_CHAPTERS


@pytest.mark.parametrize("chapter", PANEL_CHAPTERS)
def test_panel_live_in_jupyterlab(chapter: str, lab, browser) -> None:
    base, token = lab
    context = browser.new_context(viewport={"width": 1280, "height": 900}, service_workers="block")
    tab = context.new_page()
    tab.set_default_timeout(60_000)
    console: list[str] = []
    blocked: list[str] = []

    def route(r) -> None:
        if r.request.url.startswith(("http://127.0.0.1", "ws://127.0.0.1", "data:", "blob:")):
            r.continue_()
        elif r.request.url == _JSHTML_ICONS:
            # Matplotlib's to_jshtml() animations link this stylesheet for their button icons;
            # the HTML book serves a local copy (tools/book_offline.py), JupyterLab shows the
            # stored output as it is: offline the buttons lose their icons and still work
            # (README, "JupyterLab as the book"). Blocked here, and not counted.
            r.abort("internetdisconnected")
        else:
            blocked.append(r.request.url)
            r.abort("internetdisconnected")

    tab.route("**/*", route)
    tab.on("console", lambda m: m.type in ("error", "warning") and console.append(f"{m.type}: {m.text}"))
    tab.on("pageerror", lambda exc: console.append(f"exception: {exc} {(exc.stack or '')[:300]}"))
    try:
        tab.goto(f"{base}/lab/tree/{chapter}?token={token}&reset", wait_until="load")
        tab.wait_for_function("() => window.jupyterapp && window.jupyterapp.shell.currentWidget "
                              "&& window.jupyterapp.shell.currentWidget.sessionContext "
                              "&& window.jupyterapp.shell.currentWidget.sessionContext.session "
                              "&& window.jupyterapp.shell.currentWidget.sessionContext.session.kernel")
        tab.wait_for_function("() => window.jupyterapp.shell.currentWidget.sessionContext.session.kernel.status === 'idle'")
        # jupyterlab-myst renders the markdown (the cells in view at least, the title first).
        tab.wait_for_function("() => Array.from(document.querySelectorAll('.jp-MarkdownCell .myst'))"
                              ".some(e => e.textContent.trim().length > 0)")
        # No exercise/solution directive left as text.
        raw = tab.locator(".jp-MarkdownCell .myst:has-text(':label:')").count()
        assert raw == 0, f"{raw} markdown cell(s) of {chapter} show raw MyST directives"
        # Glued numbers show as values, from the stored outputs, before any cell runs.
        _check_glued_values(tab, chapter, expected=_glued_texts(chapter))

        started = time.monotonic()
        tab.evaluate("() => window.jupyterapp.commands.execute('notebook:run-all-cells')")
        tab.wait_for_function(
            """() => {
                const nb = window.jupyterapp.shell.currentWidget;
                const kernel = nb.sessionContext.session.kernel;
                const cells = nb.content.widgets.filter(c => c.model.type === 'code');
                return kernel.status === 'idle' && cells.every(c => c.model.executionCount !== null
                    && !c.node.querySelector('.jp-InputArea-prompt')?.textContent.includes('*'));
            }""",
            timeout=RUN_TIMEOUT_MS,
        )
        run_s = time.monotonic() - started
        errors = tab.evaluate(
            """() => window.jupyterapp.shell.currentWidget.content.widgets
                .filter(c => c.model.type === 'code')
                .flatMap(c => c.model.outputs.toJSON())
                .filter(o => o.output_type === 'error')
                .map(o => o.ename + ': ' + o.evalue)"""
        )
        assert not errors, f"{chapter}: error output(s): {errors[:3]}"
        # Running the chapter ran its markdown cells too: jupyterlab-myst evaluated their
        # expressions in the kernel (`glued`, this run's values): none failed.
        _check_glued_values(tab, chapter, expected=[])

        panel = tab.locator(".jp-OutputArea-output .widget-vbox:has(.widget-gridbox)").last
        panel.scroll_into_view_if_needed()
        figure = panel.locator(".widget-output img").first
        figure.wait_for(state="visible")
        before = figure.get_attribute("src")
        handle = panel.locator(".widget-gridbox .noUi-handle").first
        if handle.count():
            readout = panel.locator(".widget-gridbox .widget-readout").first
            shown = readout.inner_text() if readout.count() else None
            for _ in range(3):  # a key press that lands before the slider listens moves nothing: press again
                handle.focus()
                tab.keyboard.press("ArrowRight")
                if shown is None or _changes(tab, readout, shown):
                    break
            moved = "slider"
        else:
            select = panel.locator(".widget-gridbox select").first
            options = select.locator("option").all_inner_texts()
            current = select.input_value()
            select.select_option(index=(options.index(current) + 1) % len(options) if current in options else 1)
            moved = "drop-down"
        tab.wait_for_function(
            """([el, before]) => { const img = el.querySelector('.widget-output img');
                                   return img && img.getAttribute('src') !== before; }""",
            arg=[panel.element_handle(), before],
            timeout=REDRAW_TIMEOUT_MS,
        )
        SHOTS.mkdir(parents=True, exist_ok=True)
        tab.screenshot(path=SHOTS / (chapter.replace("/", "__").removesuffix(".ipynb") + ".png"))
        opened = _check_cross_chapter_link(tab, chapter)
        print(f"{chapter}: ran in {run_s:.0f} s; moving the first {moved} redrew the figure; "
              f"the link to {opened} opened it")
        assert not blocked, f"{chapter}: requests leaving 127.0.0.1: {blocked[:5]}"
        problems = [m for m in console if not _ignorable(m)]
        assert not problems, f"{chapter}: {len(problems)} console error(s)/warning(s): {problems[:5]}"
    finally:
        context.close()


def _changes(tab, locator, text: str, timeout_s: float = 1.0) -> bool:
    """Whether ``locator``'s text differs from ``text`` within ``timeout_s``."""
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        if locator.inner_text() != text:
            return True
        tab.wait_for_timeout(50)
    return False


def _cross_chapter_links(chapter: str) -> list[tuple[int, str, str]]:
    """(cell index, link text, target) of each cross-chapter link the chapter opens with."""
    notebook = json.loads((BOOK / chapter).read_text(encoding="utf-8"))
    lab_glue.links_to_lab(notebook, BOOK / chapter, BOOK)
    links = []
    for index, cell in enumerate(notebook["cells"]):
        for entry in cell.get("metadata", {}).get(lab_glue.LINKS, []):
            if not entry["link"].startswith("["):  # an exercise of this chapter, shown as its title
                continue
            text, target = entry["link"][1:-1].split("](")
            links.append((index, text.replace("\\[", "[").replace("\\]", "]"), target))
    return links


def _check_cross_chapter_link(tab, chapter: str) -> str:
    """The chapter's first link to another notebook renders as a link (an ``<a>`` with its text) and,
    clicked, opens that notebook in JupyterLab. Returns the notebook opened."""
    links = [link for link in _cross_chapter_links(chapter) if link[2].endswith(".ipynb")]
    assert links, f"{chapter}: no cross-chapter reference to check"
    index, text, target = links[0]
    tab.evaluate("(i) => window.jupyterapp.shell.currentWidget.content.scrollToItem(i, 'center')", index)
    anchor = tab.locator(f".jp-MarkdownCell .myst a:text-is({json.dumps(text)})").first
    anchor.wait_for(state="visible")
    anchor.click()
    expected = os.path.normpath(os.path.join(os.path.dirname(chapter), target))
    tab.wait_for_function("(path) => window.jupyterapp.shell.currentWidget?.context?.path === path", arg=expected)
    return expected


def _glued_texts(chapter: str) -> list[str]:
    """The texts the chapter's glue roles show, formatted from its stored outputs."""
    notebook = json.loads((BOOK / chapter).read_text(encoding="utf-8"))
    lab_glue.to_lab(notebook, lambda doc: json.loads(((BOOK / chapter).parent / doc).read_text(encoding="utf-8")))
    return [e["result"]["data"]["text/plain"] for c in notebook["cells"] for e in c.get("metadata", {}).get("user_expressions", [])]


def _check_glued_values(tab, chapter: str, expected: list[str]) -> None:
    """No glue role or inline expression left unrendered or failed in the rendered markdown; at
    least one of the ``expected`` texts shown (JupyterLab renders only the cells near the view)."""
    shown = tab.evaluate(
        """() => Array.from(document.querySelectorAll('.jp-MarkdownCell .myst'))
                 .map(e => e.textContent).join('\\n')"""
    )
    for raw in ("glue:text", 'glued("', "Unexecuted inline expression", "KeyError", "NameError"):
        assert raw not in shown, f"{chapter}: the rendered markdown shows {raw!r}"
    if expected:
        assert any(text in shown for text in expected), f"{chapter}: none of its glued values is shown: {len(shown)} {shown[:1500]!r} {expected[:5]}"


def _ignorable(message: str) -> bool:
    """Console messages of JupyterLab itself that say nothing about the book."""
    return any(
        text in message
        for text in (
            # The widget manager's JSON-schema validator (ajv) compiling its own schema in
            # strict mode; the widgets render (the figure change above proves it).
            "strict mode: use allowUnionTypes",
            # The browser's own line for the request to _JSHTML_ICONS aborted above.
            "Failed to load resource: net::ERR_INTERNET_DISCONNECTED",
        )
    )
