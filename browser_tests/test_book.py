"""Every page of the built book in a real browser, with the network cut off.

For each HTML page of _build/html (found by walking the build, so new chapters are tested
without listing them here), served on 127.0.0.1:

- every request that leaves 127.0.0.1 is blocked and counted: there must be none, since
  the book serves MathJax and the icons itself;
- no console error or warning, no uncaught exception, no failed request (network error or
  HTTP >= 400);
- every formula (Sphinx marks each one with class ``math``) is typeset by MathJax, without
  a TeX error;
- every image has loaded;
- every figure is legible: its smallest text (the smallest font size of the book's style,
  pfcourse/book/style.py, at the figure's dpi) scaled by displayed/natural width is >= 8 px;
- every ``to_jshtml()`` animation plays (the frame shown changes after pressing play) and
  can be scrubbed (moving its slider changes the frame), and its buttons show icons;
- every chapter reads in one sitting: at most 20 screen-heights at 1280 x 900 (15 for Part III);
- every exercise is titled "Exercise n.m: Title", numbered by chapter;
- on a 420 px window (a phone) the page does not scroll sideways, no figure is wider than its output
  (none scrolls sideways inside it: a figure too wide to read scaled to the column carries a narrow
  copy, pfcourse/book/narrow_figures.py) and every figure's text is still at least 8 px;
- every control panel works without a kernel, with no greyed control: each control, moved, shows
  the figure of the new grid point (or, for a control outside the main grid, its one-factor
  figure) within 100 ms (pfcourse/book/static_panel.py); no widget
  view is left for a widget manager (the book loads none);
- nothing is cut off at 1280 px or at 420 px (issue 39): a code or output block, a table, a display
  or an inline formula wider than its box scrolls in it (no ``overflow: hidden`` clipping it) and
  shows that it does (its hidden side fades out, web/static/pfcourse-render.js; a scrollbar is not
  enough: phones and overlay scrollbars hide it), and none reaches past the column;
- no punctuation mark right after an inline formula starts a line alone, at 1280 px and at 420 px;
- every cross-reference shows its number: no link reads a bare "Exercise", "Section", "Fig." ...,
  and no "??" is left in the text;
- a full-page screenshot is saved to _build/browser/screenshots/.

The same checks run on each page opened from disk (file://), as a reader opening
_build/html/index.html would.

A last test checks every internal link of every page: the target file exists and, for a
``#fragment``, the target page has an element with that id.
"""

from __future__ import annotations

import html.parser
import re
from functools import lru_cache
from pathlib import Path
from urllib.parse import unquote, urlsplit

import pytest
from playwright.sync_api import TimeoutError as PlaywrightTimeoutError

from conftest import HTML, SCREENSHOTS, book_pages

PAGES = book_pages()
#: The smallest text a figure may show on screen, in CSS pixels (issue 19).
MIN_TEXT_PX = 8.0
#: Console warnings that are not the book's to fix, each with its reason (none: the pages
#: load no widget manager since the panels are static, so its schema validator's
#: "strict mode: use allowUnionTypes" warnings are gone at the source).
_IGNORED_WARNINGS: tuple[str, ...] = ()
#: A control of a static panel must show its new figure within this time (issue 19).
PANEL_SWITCH_MS = 100
#: The built book's size limit (issue 19).
BOOK_LIMIT_MB = 100
LOAD_TIMEOUT_MS = 60_000
FRAME_TIMEOUT_MS = 10_000
MATH_TIMEOUT_MS = 30_000


def _screenshot_path(page: str) -> Path:
    return SCREENSHOTS / (page.removesuffix(".html").replace("/", "__") + ".png")


@pytest.mark.parametrize("page", PAGES)
def test_page_renders_offline(page: str, base_url: str, browser) -> None:
    """The page served over HTTP on 127.0.0.1, every other address blocked; with a screenshot."""
    _check_page(browser, base_url, page, screenshot=_screenshot_path(page))


@pytest.mark.parametrize("page", PAGES)
def test_page_renders_from_disk(page: str, browser) -> None:
    """The page opened as a file (the README says: open _build/html/index.html), no network."""
    _check_page(browser, HTML.as_uri() + "/", page, screenshot=None)


def _check_page(browser, base: str, page: str, screenshot: Path | None) -> None:
    """Load base + page with every request outside base blocked, run every check, report all."""
    context = browser.new_context(viewport={"width": 1280, "height": 900}, service_workers="block")
    tab = context.new_page()
    tab.set_default_timeout(LOAD_TIMEOUT_MS)
    blocked: list[str] = []
    failed: list[str] = []
    console_errors: list[str] = []
    page_errors: list[str] = []
    problems: list[str] = []
    counts: dict[str, int] = {}

    def route(r) -> None:
        if r.request.url.startswith(base):
            r.continue_()
        else:
            blocked.append(r.request.url)
            r.abort("internetdisconnected")

    def check(name: str, function) -> None:
        """Run one check; its failure is recorded and the other checks still run."""
        try:
            counts[name] = function(tab)
        except Exception as exc:  # noqa: BLE001 (a failed check of any kind is reported)
            problems.append(f"{name}: {type(exc).__name__}: {str(exc).splitlines()[0]}")

    tab.route("**/*", route)
    tab.on("console", lambda m: _is_problem(m) and console_errors.append(f"{m.type}: {m.text} ({m.location.get('url')})"))
    tab.on("pageerror", lambda exc: page_errors.append(str(exc)))
    tab.on("requestfailed", lambda r: r.url.startswith(base) and failed.append(f"{r.url}: {r.failure}"))
    tab.on("response", lambda r: r.status >= 400 and failed.append(f"{r.url}: HTTP {r.status}"))
    try:
        tab.goto(base + page, wait_until="load")
        tab.wait_for_load_state("networkidle")  # and follow a redirect page (index.html)
        check("math", _check_math)
        check("panels", _check_panels)
        check("animations", _check_animations)
        check("images", _check_images)
        check("legible figures", _check_figure_text)
        check("screen-heights", lambda tab: _check_page_height(tab, page))
        check("exercise titles", _check_exercise_titles)
        check("legible at 420 px", _check_narrow)
        check("nothing cut off at 1280 px", lambda tab: _check_overflow(tab, 1280))
        check("nothing cut off at 420 px", lambda tab: _check_overflow(tab, NARROW_PX))
        check("punctuation after formulas at 1280 px", lambda tab: _check_math_punctuation(tab, 1280))
        check("punctuation after formulas at 420 px", lambda tab: _check_math_punctuation(tab, NARROW_PX))
        check("cross-references", _check_references)
        if screenshot is not None:
            # From the top, with nothing focused (a focused "skip to content" link would show).
            tab.evaluate("() => { document.activeElement && document.activeElement.blur(); window.scrollTo(0, 0); }")
            screenshot.parent.mkdir(parents=True, exist_ok=True)
            tab.screenshot(path=screenshot, full_page=True)
    finally:
        context.close()

    print(f"{base + page}: " + ", ".join(f"{n} {name}" for name, n in counts.items()))
    if blocked:
        problems.append(f"{len(blocked)} request(s) leaving {base} (blocked): {blocked[:5]}")
    if failed:
        problems.append(f"{len(failed)} failed request(s): {failed[:5]}")
    if page_errors:
        problems.append(f"{len(page_errors)} uncaught exception(s): {page_errors[:5]}")
    if console_errors:
        problems.append(f"{len(console_errors)} console error(s)/warning(s): {console_errors[:5]}")
    assert not problems, f"{base + page}:\n- " + "\n- ".join(problems)


def _check_math(tab) -> int:
    """Every formula (Sphinx gives each one the class ``math``) is typeset, without TeX error."""
    if not tab.locator(".math").count():
        return 0
    # MathJax typesets after the page has loaded: wait for the end of its first pass.
    try:
        tab.wait_for_function(
            "() => window.MathJax && MathJax.startup && MathJax.startup.promise"
            " && MathJax.startup.promise.then(() => true)",
            timeout=MATH_TIMEOUT_MS,
        )
    except PlaywrightTimeoutError:
        raise AssertionError(
            f"MathJax did not typeset the page within {MATH_TIMEOUT_MS / 1000:.0f} s"
            " (is its script missing or blocked?)"
        ) from None
    math = tab.evaluate(
        """() => {
            const formulas = Array.from(document.querySelectorAll('.math'));
            return {
                formulas: formulas.length,
                raw: formulas.filter(el => !el.querySelector('mjx-container'))
                    .map(el => el.textContent.slice(0, 80)),
                errors: Array.from(document.querySelectorAll('mjx-merror'))
                    .map(el => el.getAttribute('data-mjx-error') || el.textContent),
            };
        }"""
    )
    assert not math["raw"], f"{len(math['raw'])} formula(s) not typeset: {math['raw'][:3]}"
    assert not math["errors"], f"TeX errors: {math['errors'][:3]}"
    return math["formulas"]


def _check_images(tab) -> int:
    """Every image (figures, animation frames, the logo) has loaded."""
    tab.wait_for_load_state("networkidle")
    images = tab.evaluate(
        """() => Array.from(document.images).map(img => ({
            ok: img.complete && img.naturalWidth > 0,
            src: (img.currentSrc || img.src || '(no src)').slice(0, 100)}))"""
    )
    broken = [img["src"] for img in images if not img["ok"]]
    assert not broken, f"{len(broken)} image(s) not loaded: {broken[:5]}"
    return len(images)


def _is_problem(message) -> bool:
    """A console message the test fails on: any error, and any warning not justified above."""
    if message.type == "error":
        return True
    return message.type == "warning" and not any(w in message.text for w in _IGNORED_WARNINGS)


def _smallest_font_px() -> float:
    """The smallest font of the book's figure style, in the figure's natural pixels."""
    import matplotlib as mpl
    from matplotlib.font_manager import FontProperties

    from pfcourse.book.style import STYLE

    with mpl.rc_context(STYLE):
        sizes = [
            FontProperties(size=mpl.rcParams[key]).get_size_in_points()
            for key in ("font.size", "axes.titlesize", "axes.labelsize", "legend.fontsize",
                        "xtick.labelsize", "ytick.labelsize")
        ]
        return min(sizes) * mpl.rcParams["savefig.dpi"] / 72.0


#: A chapter reads in one sitting: at most this many screen-heights at 1280 x 900 (issue 29: Part III
#: was 44, Part V 29; the longest chapter now, terrain with its map, flight, animation and panel, is 19),
#: and the pages of Part III, split for it, at most 15 (issue 30).
MAX_SCREENS = {"book/part3/": 15.0, "book/part": 20.0}


def _check_page_height(tab, page: str) -> int:
    """The page's height in screen-heights of the 900 px window, under its part's limit."""
    limit = next((v for prefix, v in MAX_SCREENS.items() if page.startswith(prefix)), None)
    screens = tab.evaluate("() => document.documentElement.scrollHeight") / 900
    assert limit is None or screens <= limit, f"{screens:.1f} screen-heights (limit {limit:.0f})"
    return round(screens)


NARROW_PX = 420


def _check_narrow(tab) -> int:
    """On a phone-width window (NARROW_PX): the page does not scroll sideways, no figure is wider than
    its output (none scrolls sideways inside it: wide figures carry a narrow copy, served there by a
    ``<picture>`` or the panel's script, pfcourse/book/narrow_figures.py), and every figure's smallest text
    is still >= MIN_TEXT_PX. Leaves the window at 1280 px."""
    tab.set_viewport_size({"width": NARROW_PX, "height": 900})
    try:
        tab.wait_for_timeout(100)  # one layout pass
        tab.evaluate("""() => Promise.all(Array.from(document.querySelectorAll('div.cell_output img'))
            .map(img => img.decode().catch(() => null)))""")  # the narrow copies the window now selects
        width = tab.evaluate("() => document.documentElement.scrollWidth")
        assert width <= NARROW_PX + 1, f"the page scrolls sideways at {NARROW_PX} px ({width} px wide)"
        wide = tab.evaluate(
            """() => Array.from(document.querySelectorAll('div.cell_output img, .animation img'))
                .filter(img => img.naturalWidth > 0 && img.getBoundingClientRect().width > 0)
                .map(img => {
                    const box = img.closest('div.pfcourse-panel, div.animation, div.cell_output');
                    const output = img.closest('div.cell_output') || box;
                    return {shown: img.getBoundingClientRect().width, room: box.clientWidth,
                            scrolls: output.scrollWidth > output.clientWidth + 1,
                            src: (img.currentSrc || img.src || '').slice(0, 60)};
                })
                .filter(f => f.shown > f.room + 1 || f.scrolls)"""
        )
        assert not wide, (f"{len(wide)} figure(s) wider than their output at {NARROW_PX} px (they scroll "
                          f"sideways): {[(round(f['shown']), f['room'], f['src']) for f in wide[:5]]}")
        return _check_figure_text(tab)
    finally:
        tab.set_viewport_size({"width": 1280, "height": 900})


def _at_width(tab, width: int) -> None:
    """Resize the window and wait for the page's layout at that width, including the pass of
    web/static/pfcourse-render.js (it marks <html> with the width it laid out for)."""
    tab.set_viewport_size({"width": width, "height": 900})
    tab.wait_for_timeout(100)
    # The theme settles its sidebars over a few frames after a resize: wait for the article's width
    # to hold still between two polls, and for the script's pass at that width.
    tab.wait_for_function(
        """(width) => {
            const article = document.querySelector('article.bd-article') || document.body;
            const now = article.getBoundingClientRect().width, before = window.__pfcourseArticleWidth;
            window.__pfcourseArticleWidth = now;
            return now === before && (!document.querySelector('script[src*="pfcourse-render"]')
                || document.documentElement.dataset.pfcourseLayout === String(width));
        }""",
        arg=width, polling=150, timeout=FRAME_TIMEOUT_MS)


#: What "cut off" means, in the page: for every code or output block and table (scrollWidth past
#: clientWidth) and every typeset formula (its math wider than its box, the box being the display
#: formula's container or the inline formula's span.math, which the theme clips): it must scroll
#: (overflow-x auto or scroll) and show that it does, by a fading edge (a mask gradient) or a
#: scrollbar that takes room (headless chromium hides scrollbars, so a fade is what counts here).
#: Nothing may reach past the article's column either.
_OVERFLOW_JS = r"""() => {
  const article = document.querySelector('article.bd-article') || document.querySelector('main') || document.body;
  const edge = article.getBoundingClientRect().right;
  const visible = (el) => { const r = el.getBoundingClientRect(); return r.width > 0 && r.height > 0; };
  const label = (el) => (el.textContent || '').trim().replace(/\s+/g, ' ').slice(0, 50);
  const scrolls = (el) => ['auto', 'scroll'].includes(getComputedStyle(el).overflowX);
  const cued = (el) => {
    const s = getComputedStyle(el);
    const fade = /gradient/.test(s.maskImage || '') || /gradient/.test(s.webkitMaskImage || '');
    const bar = el.offsetHeight - el.clientHeight
      - parseFloat(s.borderTopWidth) - parseFloat(s.borderBottomWidth) > 0;
    return fade || bar;
  };
  // Past the column is a fault only for what no box around it scrolls.
  const inScroller = (el) => {
    for (let e = el.parentElement; e && e !== article; e = e.parentElement) if (scrolls(e)) return true;
    return false;
  };
  const out = {boxes: 0, formulas: 0, displays: 0, clipped: [], uncued: [], display: [], inline: [], outside: []};
  for (const content of article.querySelectorAll('pre, table')) {
    if (!visible(content) || content.closest('mjx-container')) continue;
    // A table the theme wraps in a scrolling container (its only child): the container is the box.
    const parent = content.parentElement;
    const el = !scrolls(content) && parent && parent.children.length === 1 && scrolls(parent) ? parent : content;
    out.boxes++;
    const right = el.getBoundingClientRect().right;
    if (right > edge + 1 && !inScroller(el)) out.outside.push(`${content.tagName.toLowerCase()} ${Math.round(right - edge)} px past the column: ${label(el)}`);
    if (el.scrollWidth <= el.clientWidth + 1) continue;
    const text = `${content.tagName.toLowerCase()} (${el.scrollWidth} px in ${el.clientWidth} px): ${label(el)}`;
    if (!scrolls(el)) out.clipped.push(text);
    else if (!cued(el)) out.uncued.push(text);
  }
  for (const container of article.querySelectorAll('mjx-container')) {
    const math = container.querySelector('mjx-math');
    const display = container.getAttribute('display') === 'true';
    const box = display ? container : (container.closest('span.math') || container);
    if (!math || !visible(box)) continue;
    out.formulas++;
    if (display) out.displays++;
    const r = box.getBoundingClientRect();
    if (r.right > edge + 1 && !inScroller(box)) out.outside.push(`formula ${Math.round(r.right - edge)} px past the column: ${label(box)}`);
    const need = math.getBoundingClientRect().width;
    if (need <= r.width + 1 || (scrolls(box) && box.scrollWidth > box.clientWidth + 1 && cued(box))) continue;
    (display ? out.display : out.inline).push(
      `${Math.round(need)} px in ${Math.round(r.width)} px, ${scrolls(box) ? 'scrolls with no cue' : 'cut off'}`
      + `${box.closest('.algorithm') ? ' (algorithm box)' : ''}: ${label(box)}`);
  }
  return out;
}"""


def _check_overflow(tab, width: int) -> int:
    """At ``width``: no code/output block, table or formula cut off, or scrolling with no cue, or past
    the column (see _OVERFLOW_JS). Returns the number of boxes and formulas checked. Leaves 1280 px."""
    try:
        _at_width(tab, width)
        found = tab.evaluate(_OVERFLOW_JS)
    finally:
        if width != 1280:
            _at_width(tab, 1280)
    problems = [
        f"{len(found[key])} {what}: {found[key][:3]}"
        for key, what in [
            ("display", f"of {found['displays']} display formula(s) wider than their column"),
            ("inline", "inline formula(s) wider than their line"),
            ("clipped", "code/output block(s) or table(s) cut off (no overflow auto/scroll)"),
            ("uncued", "code/output block(s) or table(s) scrolling with no visible cue"),
            ("outside", "box(es) reaching past the column"),
        ]
        if found[key]
    ]
    assert not problems, f"at {width} px: " + "; ".join(problems)
    return found["boxes"] + found["formulas"]


#: For every inline formula followed by a punctuation mark: the mark's first character must be on the
#: formula's line (its top above the formula's bottom, and not left of the formula's start).
_PUNCTUATION_JS = r"""() => {
  const article = document.querySelector('article.bd-article') || document.querySelector('main') || document.body;
  const out = {checked: 0, orphans: []};
  for (const span of article.querySelectorAll('span.math')) {
    const math = span.querySelector('mjx-container');
    if (!math || !span.getBoundingClientRect().width) continue;
    const walker = document.createTreeWalker(article, NodeFilter.SHOW_TEXT);
    walker.currentNode = span;
    let text = walker.nextNode();
    while (text && span.contains(text)) text = walker.nextNode();
    if (!text || !/^[.,;:!?)\]]/.test(text.data)) continue;
    out.checked++;
    const range = document.createRange();
    range.setStart(text, 0);
    range.setEnd(text, 1);
    const p = range.getClientRects()[0], m = math.getBoundingClientRect();
    if (p && (p.top >= m.bottom - 1 || p.left < m.left - 1)) {
      out.orphans.push(`"${text.data[0]}" after ${(span.textContent || '').trim().slice(0, 40)}`
                       + (span.closest('.algorithm') ? ' (algorithm box)' : ''));
    }
  }
  return out;
}"""


def _check_math_punctuation(tab, width: int) -> int:
    """At ``width``: no punctuation mark after an inline formula wraps onto the next line alone."""
    try:
        _at_width(tab, width)
        found = tab.evaluate(_PUNCTUATION_JS)
    finally:
        if width != 1280:
            _at_width(tab, 1280)
    orphans = found["orphans"]
    in_boxes = sum("(algorithm box)" in o for o in orphans)
    assert not orphans, (f"at {width} px, {len(orphans)} punctuation mark(s) alone at the start of a line after "
                         f"an inline formula ({in_boxes} in algorithm boxes): {orphans[:4]}")
    return found["checked"]


#: The text of a reference whose number was lost: a label word alone (a {ref} to an unnumbered
#: exercise reads "Exercise"), or Sphinx's "??" for an unresolved number.
_BARE_REFERENCE = re.compile(
    r"^(?:Exercise|Solution|Section|Chapter|Part|Fig\.?|Figure|Table|Equation|Eq\.|Algorithm|Listing|Proof)s?$"
    r"|\?\?", re.IGNORECASE)


def _check_references(tab) -> int:
    """Every cross-reference shows its number or title; no "??" in the page's text outside code."""
    found = tab.evaluate(
        r"""() => {
            const article = document.querySelector('article.bd-article') || document.querySelector('main') || document.body;
            const refs = Array.from(article.querySelectorAll('a.reference.internal, a.reference'))
                .map(a => ({text: a.textContent.trim().replace(/\s+/g, ' '),
                            context: (a.parentElement.textContent || '').replace(/\s+/g, ' ')}));
            const copy = article.cloneNode(true);
            copy.querySelectorAll('pre, code, script, mjx-container, .highlight').forEach(e => e.remove());
            return {refs, text: copy.textContent};
        }"""
    )
    bare = []
    for ref in found["refs"]:
        if _BARE_REFERENCE.search(ref["text"]):
            i = ref["context"].find(ref["text"])
            bare.append(ref["context"][max(0, i - 40): i + len(ref["text"]) + 20])
    unresolved = [found["text"][max(0, i - 40): i + 20] for i in (m.start() for m in re.finditer(r"\?\?", found["text"]))]
    assert not bare and not unresolved, (
        f"{len(bare)} reference(s) without their number: {bare[:3]}"
        + (f"; {len(unresolved)} '??' in the text: {unresolved[:3]}" if unresolved else ""))
    return len(found["refs"])


def _check_exercise_titles(tab) -> int:
    """Exercises read "Exercise n.m: Title" (numbered by chapter), never "Exercise (n.m Title)"."""
    titles = tab.evaluate("""() => Array.from(document.querySelectorAll('.exercise .admonition-title'))
        .map(t => t.textContent.trim())""")
    wrong = [t for t in titles if not re.match(r"^Exercise \d+\.\d+: ", t)]
    assert not wrong, f"exercise titles not numbered by chapter: {wrong[:3]}"
    return len(titles)


def _check_figure_text(tab) -> int:
    """Each figure (a PNG output of a cell, an animation frame) shows its smallest text at
    >= MIN_TEXT_PX: smallest font (natural px) x displayed width / natural width."""
    smallest = _smallest_font_px()
    figures = tab.evaluate(
        """() => Array.from(document.querySelectorAll('div.cell_output img, .animation img'))
            .filter(img => img.naturalWidth > 0 && img.getBoundingClientRect().width > 0)
            .map(img => ({shown: img.getBoundingClientRect().width, natural: img.naturalWidth,
                          src: (img.currentSrc || img.getAttribute('src') || '').slice(0, 60)}))"""
    )
    small = [
        f"{f['src']} ({f['natural']} px shown at {f['shown']:.0f} px: text "
        f"{smallest * f['shown'] / f['natural']:.1f} px)"
        for f in figures
        if smallest * f["shown"] / f["natural"] < MIN_TEXT_PX
    ]
    assert not small, f"{len(small)} figure(s) with text below {MIN_TEXT_PX} px: {small[:5]}"
    return len(figures)


def _check_panels(tab) -> int:
    """Every static control panel switches figures without a kernel; returns their number.

    For each control of each panel's grid, in turn: move it to its next value, and require
    the figure of that grid point (image number = sum of index x stride, the page's data)
    within PANEL_SWITCH_MS, decoded, in the better of two tries (one stall of a loaded machine failed
    a clean-clone run at 189 ms); then move it back. Saved widget views must be absent:
    the book has no widget manager to render them.
    """
    views = tab.locator('script[type="application/vnd.jupyter.widget-view+json"]').count()
    assert views == 0, f"{views} widget view(s) in the page, which loads no widget manager"
    panels = tab.locator("div.pfcourse-panel")
    count = panels.count()
    for i in range(count):
        panel = panels.nth(i)
        panel.scroll_into_view_if_needed()
        tab.wait_for_function("el => el.classList.contains('pfcourse-panel-ready')", arg=panel.element_handle())
        result = panel.evaluate(
            """async (panel) => {
                const data = JSON.parse(panel.querySelector('script.pfcourse-panel-data').textContent);
                const img = panel.querySelector('img.pfcourse-panel-figure');
                const problems = [], times = [];
                const indices = () => data.controls.map((name, k) => data.enabled[k]
                    ? parseInt(panel.querySelector(`[name="${name}"]`).value, 10) : (data.defaults || [])[k] || 0);
                const greyed = panel.querySelectorAll('label.pfcourse-control-off').length;
                if (greyed) { problems.push(`${greyed} greyed control(s): every control must move the figure`); }
                for (let k = 0; k < data.controls.length; k++) {
                    if (!data.enabled[k]) { continue; }
                    const input = panel.querySelector(`[name="${data.controls[k]}"]`);
                    const before = input.value, n = data.labels[k].length;
                    const event = () => new Event(input.tagName === 'SELECT' ? 'change' : 'input');
                    // the better of two tries: one stall of the machine (a collection, another process)
                    // is not the page's speed; a slow page is slow twice
                    let best = Infinity;
                    for (let attempt = 0; attempt < 2; attempt++) {
                        if (attempt) { input.value = before; input.dispatchEvent(event()); await img.decode(); }
                        input.value = String((parseInt(before, 10) + 1) % n);
                        const t0 = performance.now();
                        input.dispatchEvent(event());
                        await img.decode();
                        best = Math.min(best, performance.now() - t0);
                    }
                    times.push(best);
                    const main = data.main || data.controls.map(() => true);
                    const idx = indices();
                    const expected = main[k]
                        ? idx.reduce((sum, i, j) => (main[j] ? sum + i * data.strides[j] : sum), 0)
                        : data.side[String(k)][idx[k]];  // a side control: its one-factor figure
                    // a figure is a file (tools/book_weight.py) or inline: compare resolved URLs
                    if (img.src !== new URL(data.images[expected], document.baseURI).href) {
                        problems.push(`${data.controls[k]}: figure ${expected} not shown`);
                    }
                    input.value = before;
                    input.dispatchEvent(new Event(input.tagName === 'SELECT' ? 'change' : 'input'));
                }
                return {problems, slowest: Math.max(0, ...times), figures: data.images.length};
            }"""
        )
        assert not result["problems"], f"panel {i + 1}: {result['problems']}"
        assert result["slowest"] <= PANEL_SWITCH_MS, (
            f"panel {i + 1}: a switch took {result['slowest']:.0f} ms (limit {PANEL_SWITCH_MS} ms)")
    return count


def test_book_weight() -> None:
    """The built book stays under BOOK_LIMIT_MB; each page's size is printed (panels carry figures)."""
    total = sum(f.stat().st_size for f in HTML.rglob("*") if f.is_file())
    for page in PAGES:
        print(f"{page}: {(HTML / page).stat().st_size / 1e6:.2f} MB")
    print(f"the whole book: {total / 1e6:.1f} MB")
    assert total < BOOK_LIMIT_MB * 1e6, f"the built book weighs {total / 1e6:.0f} MB (limit {BOOK_LIMIT_MB} MB)"


def _check_animations(tab) -> int:
    """Every matplotlib to_jshtml() animation plays and scrubs; returns their number."""
    animations = tab.locator("div.animation")
    count = animations.count()
    for i in range(count):
        anim = animations.nth(i)
        anim.scroll_into_view_if_needed()
        img = anim.locator("img").first
        slider = anim.locator("input[type=range]").first
        assert int(slider.get_attribute("max") or slider.evaluate("s => s.max")) > 0, "one frame only"
        first = img.evaluate("img => img.src")
        anim.locator("button[title='Play']").click()
        img.evaluate(
            """(img, first) => new Promise((resolve, reject) => {
                const t0 = Date.now();
                const poll = () => img.src !== first ? resolve(true)
                    : Date.now() - t0 > %d ? reject(new Error('the frame did not change after play'))
                    : setTimeout(poll, 50);
                poll();
            })""" % FRAME_TIMEOUT_MS,
            first,
        )
        anim.locator("button[title='Pause']").click()
        anim.locator("button[title='First frame']").click()
        assert img.evaluate("img => img.src") == first, "'First frame' did not show the first frame"
        slider.evaluate("s => { s.value = s.max; s.dispatchEvent(new Event('input')); }")
        assert img.evaluate("img => img.src") != first, "moving the slider did not change the frame"
        # Icons: the theme's Font Awesome 6 script turns each <i class="fa ..."> into an SVG;
        # without it they are glyphs of the book's own Font Awesome 4 (the CDN link of
        # matplotlib's template is rewritten by tools/book_offline.py).
        missing = anim.locator("button").evaluate_all(
            """buttons => buttons.filter(b => !b.querySelector('svg[data-icon] path')
                && !Array.from(b.querySelectorAll('i.fa')).some(i => getComputedStyle(i, '::before')
                    .fontFamily.includes('FontAwesome') && document.fonts.check('14px FontAwesome')))
                .map(b => b.title)"""
        )
        assert not missing, f"animation buttons without an icon: {missing}"
    return count


# --- internal links ------------------------------------------------------------------


class _LinksAndIds(html.parser.HTMLParser):
    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.links: list[str] = []
        self.ids: set[str] = set()

    def handle_starttag(self, tag: str, attrs) -> None:
        attributes = dict(attrs)
        if attributes.get("id"):
            self.ids.add(attributes["id"])
        if tag == "a" and attributes.get("name"):
            self.ids.add(attributes["name"])
        if tag == "a" and attributes.get("href"):
            self.links.append(attributes["href"])


@lru_cache(maxsize=None)
def _parse(path: Path) -> _LinksAndIds:
    parser = _LinksAndIds()
    parser.feed(path.read_text(encoding="utf-8"))
    return parser


EXTERNAL = re.compile(r"^[a-z][a-z0-9+.-]*:", re.IGNORECASE)  # http:, mailto:, javascript:, ...


def test_internal_links_resolve() -> None:
    """Every internal link of every page points to an existing file and, if any, anchor."""
    assert PAGES
    broken = []
    checked = 0
    for page in PAGES:
        source = HTML / page
        for href in _parse(source).links:
            if EXTERNAL.match(href) or href in ("", "#"):
                continue
            parts = urlsplit(href)
            target = source if not parts.path else (source.parent / unquote(parts.path)).resolve()
            if target.is_dir():
                target = target / "index.html"
            checked += 1
            if not target.is_relative_to(HTML.resolve()) or not target.exists():
                broken.append(f"{page}: {href} (no file {target})")
            elif parts.fragment and target.suffix == ".html":
                if unquote(parts.fragment) not in _parse(target).ids:
                    broken.append(f"{page}: {href} (no id {parts.fragment!r} in {target.name})")
    print(f"{checked} internal links checked on {len(PAGES)} pages")
    assert not broken, f"{len(broken)} broken internal link(s):\n" + "\n".join(broken[:30])
