"""The HTML book in dark mode (issue 33): the panels' text reads, and every figure sits on a light card.

The pydata theme switches to dark mode on ``html[data-theme=dark]`` (a reader's choice, kept in
``localStorage.mode``). It paints every HTML output a light grey box with dark text, and darkens
images a little; matplotlib's figures are drawn on white (or transparent) with dark text. For
every page of the built book that shows a figure or a panel, opened in dark mode:

- every figure image (the outputs' ``img`` and the panels' figures) has an opaque light background
  of its own (relative luminance at least :data:`MIN_CARD_LUMINANCE`) with some padding around the
  figure, so a transparent or white PNG never meets the dark page;
- every text of a panel (control labels, readouts, the values under a slider, the hint under the
  controls, and the note a combination that was not computed shows) has a contrast ratio of at
  least 4.5 (WCAG AA, normal text) against the background it is drawn on (the page's colours
  composited from the element up);
- every evidence block (``details.pfcourse-evidence``, pfcourse/book/report.py) sits on the same
  dark background, closed and open, whether or not it holds a table (issue 39: the theme painted
  the ones without a table a light slab), and its text reads on it (contrast ratio at least 4.5).
"""

from __future__ import annotations

import re

import pytest

from conftest import HTML, book_pages



def _shows_a_figure(text: str) -> bool:
    """A cell output holding an image (the figures of a page), or a panel's figure."""
    return "pfcourse-panel-figure" in text or re.search(r'cell_output[^>]*>(?:(?!</div>).)*?<img', text, re.S) is not None


_TEXTS = {page: (HTML / page).read_text(encoding="utf-8", errors="replace") for page in book_pages()}
PAGES = [page for page, text in _TEXTS.items() if _shows_a_figure(text)]
PANEL_PAGES = [page for page in PAGES if "pfcourse-panel-figure" in _TEXTS[page]]
EVIDENCE_PAGES = [page for page, text in _TEXTS.items() if 'class="pfcourse-evidence"' in text]
#: Evidence blocks alike: no colour channel of their backgrounds further apart than this (0-255).
MAX_EVIDENCE_SPREAD = 8
#: ... and dark (relative luminance at most this; the page itself is about 0.007).
MAX_EVIDENCE_LUMINANCE = 0.05
#: WCAG 2 contrast ratio for normal text (level AA).
MIN_CONTRAST = 4.5
#: The figure card's relative luminance (white: 1; the theme's light grey #ced6dd: about 0.66).
MIN_CARD_LUMINANCE = 0.9
#: The card's padding around a figure, in CSS px.
MIN_PADDING_PX = 4.0

#: Colour arithmetic in the page: the background an element's text is drawn on (each ancestor's
#: background composited over the ones below it, the page's last), WCAG's relative luminance and
#: contrast ratio.
_COLOURS = """
const parse = (c) => { const m = c.match(/rgba?\\(([^)]+)\\)/); if (!m) return [0, 0, 0, 0];
  const v = m[1].split(/[ ,\\/]+/).filter(Boolean).map(Number); return [v[0], v[1], v[2], v.length > 3 ? v[3] : 1]; };
const over = (top, below) => { const a = top[3] + below[3] * (1 - top[3]);
  if (a === 0) return [0, 0, 0, 0];
  return [0, 1, 2].map(i => (top[i] * top[3] + below[i] * below[3] * (1 - top[3])) / a).concat([a]); };
const background = (el) => { const layers = [];
  for (let e = el; e; e = e.parentElement) layers.push(parse(getComputedStyle(e).backgroundColor));
  let colour = [255, 255, 255, 1];  // the canvas under <html>, if nothing else is opaque
  for (const layer of layers.reverse()) colour = over(layer, colour);
  return colour; };
const luminance = (c) => { const f = (v) => { v /= 255; return v <= 0.03928 ? v / 12.92 : Math.pow((v + 0.055) / 1.055, 2.4); };
  return 0.2126 * f(c[0]) + 0.7152 * f(c[1]) + 0.0722 * f(c[2]); };
const contrast = (a, b) => { const [l1, l2] = [luminance(a), luminance(b)].sort((x, y) => y - x); return (l1 + 0.05) / (l2 + 0.05); };
"""


def _dark_tab(browser, page: str, base_url: str):
    context = browser.new_context(viewport={"width": 1280, "height": 900}, service_workers="block")
    context.add_init_script("localStorage.setItem('mode', 'dark'); localStorage.setItem('theme', 'dark');")
    tab = context.new_page()
    tab.route("**/*", lambda r: r.continue_() if r.request.url.startswith(base_url)
              else r.abort("internetdisconnected"))
    tab.goto(base_url + page, wait_until="load")
    assert tab.evaluate("() => document.documentElement.dataset.theme") == "dark", f"{page}: not in dark mode"
    return context, tab


def test_pages_found() -> None:
    assert len(PAGES) >= 20 and len(PANEL_PAGES) >= 5, (len(PAGES), len(PANEL_PAGES))
    assert len(EVIDENCE_PAGES) >= 15, len(EVIDENCE_PAGES)


@pytest.mark.parametrize("page", PAGES)
def test_figures_sit_on_a_light_card_in_dark_mode(page: str, base_url: str, browser) -> None:
    context, tab = _dark_tab(browser, page, base_url)
    try:
        cards = tab.evaluate("() => {" + _COLOURS + """
            return Array.from(document.querySelectorAll('div.cell_output img, img.pfcourse-panel-figure'))
              .map(img => { const s = getComputedStyle(img); const c = parse(s.backgroundColor);
                            return {alt: (img.alt || img.src.slice(0, 40)), alpha: c[3], luminance: luminance(c),
                                    padding: Math.min(...['Top', 'Right', 'Bottom', 'Left'].map(k => parseFloat(s['padding' + k])))}; });
        }""")
        assert cards, f"{page}: no figure found"
        bad = [c for c in cards if c["alpha"] < 1 or c["luminance"] < MIN_CARD_LUMINANCE or c["padding"] < MIN_PADDING_PX]
        assert not bad, f"{page}: {len(bad)} of {len(cards)} figures without an opaque light card: {bad[:3]}"
    finally:
        context.close()


@pytest.mark.parametrize("page", PANEL_PAGES)
def test_panel_text_reads_in_dark_mode(page: str, base_url: str, browser) -> None:
    context, tab = _dark_tab(browser, page, base_url)
    try:
        panel = tab.locator("div.pfcourse-panel.pfcourse-panel-ready").first
        panel.wait_for(state="attached")
        # Show the "not computed" note where the panel has a side control: that control moved off
        # its first value, then a main control.
        moved = tab.evaluate("""(panel) => {
            const data = JSON.parse(panel.querySelector('script.pfcourse-panel-data').textContent);
            const input = (k) => data.enabled[k] ? panel.querySelector('[name="' + data.controls[k] + '"]') : null;
            const side = data.controls.findIndex((_, k) => !data.main[k] && input(k));
            const main = data.controls.findIndex((_, k) => data.main[k] && input(k));
            if (side < 0 || main < 0) return false;
            for (const k of [side, main]) {
              const el = input(k); const n = data.labels[k].length;
              el.value = String((data.defaults[k] + 1) % n); el.dispatchEvent(new Event('change'));
            }
            return true;
        }""", panel.element_handle())
        texts = tab.evaluate("(panel) => {" + _COLOURS + """
            const selector = 'label.pfcourse-control > span, .pfcourse-readout, small.pfcourse-ticks, '
                           + 'p.pfcourse-panel-note, p.pfcourse-panel-nearest:not([hidden])';
            return Array.from(panel.querySelectorAll(selector)).filter(e => e.textContent.trim())
              .map(e => { const bg = background(e); const fg = over(parse(getComputedStyle(e).color), bg);
                          return {text: e.textContent.trim().slice(0, 40), cls: e.className, ratio: contrast(fg, bg)}; });
        }""", panel.element_handle())
        classes = {t["cls"] for t in texts}
        assert "pfcourse-panel-note" in classes and (not moved or "pfcourse-panel-nearest" in classes), texts
        low = [t for t in texts if t["ratio"] < MIN_CONTRAST]
        assert not low, f"{page}: {len(low)} panel text(s) under a {MIN_CONTRAST} contrast ratio in dark mode: {low[:4]}"
        print(f"{page}: {len(texts)} panel texts, lowest contrast {min(t['ratio'] for t in texts):.1f}")
    finally:
        context.close()


@pytest.mark.parametrize("page", EVIDENCE_PAGES)
def test_evidence_blocks_alike_in_dark_mode(page: str, base_url: str, browser) -> None:
    context, tab = _dark_tab(browser, page, base_url)
    try:
        blocks = tab.evaluate("() => {" + _COLOURS + """
            const blocks = Array.from(document.querySelectorAll('details.pfcourse-evidence'));
            const look = (d) => { const s = d.querySelector('summary'); const bg = background(s);
                                  const fg = over(parse(getComputedStyle(s).color), bg);
                                  return {bg: bg.slice(0, 3).map(Math.round), luminance: luminance(bg),
                                          ratio: contrast(fg, bg)}; };
            return blocks.map(d => { const closed = look(d); d.open = true; const open = look(d); d.open = false;
                                     return {title: d.querySelector('summary').textContent.trim().slice(0, 50),
                                             table: !!d.querySelector('table'), closed, open}; });
        }""")
        assert blocks, f"{page}: no evidence block found"
        looks = [(b["title"], b["table"], state, b[state]) for b in blocks for state in ("closed", "open")]
        spread = max(max(look[3]["bg"][i] for look in looks) - min(look[3]["bg"][i] for look in looks) for i in range(3))
        light = [(t, table, state, look["bg"]) for t, table, state, look in looks if look["luminance"] > MAX_EVIDENCE_LUMINANCE]
        low = [(t, state, round(look["ratio"], 1)) for t, _, state, look in looks if look["ratio"] < MIN_CONTRAST]
        assert not light and spread <= MAX_EVIDENCE_SPREAD, (
            f"{page}: evidence blocks not alike in dark mode (backgrounds {spread} apart in a colour channel); "
            f"{len(light)} of {len(looks)} on a light background (title, has a table, state, rgb): {light[:3]}")
        assert not low, f"{page}: evidence block text under a {MIN_CONTRAST} contrast ratio in dark mode: {low[:3]}"
        print(f"{page}: {len(blocks)} evidence blocks, background {looks[0][3]['bg']}")
    finally:
        context.close()
