/* pfcourse: what the HTML book does to its text once MathJax has typeset it (issue 39, item 8).
   MathJax 3 does not break a formula over lines, and the theme clips inline math at its line's
   width (span.math: overflow hidden), so:
   - a formula (display or inline) wider than its column is shrunk to fit when that takes no more
     than MIN_SCALE of its size; a wider one scrolls sideways in its own box;
   - every box that scrolls sideways (a display formula, an inline formula, a code or output
     block, a wide table) shows it: its hidden side fades out (class pfcourse-more-right /
     pfcourse-more-left, pfcourse.css), as a scrollbar alone is invisible on phones and with
     overlay scrollbars;
   - a punctuation mark right after an inline formula (or an opening bracket right before it)
     is bound to it, so that ";" never starts a line alone.
   Redone when the window's width changes.  When a pass is done, <html> carries
   data-pfcourse-layout = the window's width it was made for (the browser test waits for it). */
(function () {
  "use strict";
  var MIN_SCALE = 0.8;
  var SCROLLERS = "div.highlight pre, div.cell_output pre, pre.literal-block, div.cell_output table, "
    + "div.pst-scrollable-table-container, div.math > mjx-container, span.math.pfcourse-math-scrolls";
  var TRAILING = /^[.,;:!?)\]\u2019\u201d]+/;
  var LEADING = /[(\[\u2018\u201c]+$/;

  function bindPunctuation(root) {
    root.querySelectorAll("span.math").forEach(function (span) {
      if (!span.querySelector("mjx-container") || span.closest(".pfcourse-nobreak")) { return; }
      var next = span.nextSibling, prev = span.previousSibling;
      var after = next && next.nodeType === Node.TEXT_NODE ? TRAILING.exec(next.data) : null;
      var before = prev && prev.nodeType === Node.TEXT_NODE ? LEADING.exec(prev.data) : null;
      if (!after && !before) { return; }
      var group = document.createElement("span");
      group.className = "pfcourse-nobreak";
      span.parentNode.insertBefore(group, span);
      if (before) {
        prev.data = prev.data.slice(0, before.index);
        group.appendChild(document.createTextNode(before[0]));
      }
      group.appendChild(span);
      if (after) {
        next.data = next.data.slice(after[0].length);
        group.appendChild(document.createTextNode(after[0]));
      }
    });
  }

  /* The width a formula needs (its typeset math) and the width its box has. */
  function mathWidths(box) {
    var math = box.querySelector("mjx-math");
    return math ? {need: math.getBoundingClientRect().width, room: box.getBoundingClientRect().width} : null;
  }

  function fitFormulas(root) {
    var boxes = Array.prototype.slice.call(root.querySelectorAll("div.math > mjx-container, span.math"));
    boxes.forEach(function (box) {  // back to the size MathJax gave it
      var container = box.matches("mjx-container") ? box : box.querySelector("mjx-container");
      if (!container) { return; }
      if (container.dataset.pfcourseSize === undefined) { container.dataset.pfcourseSize = container.style.fontSize; }
      container.style.fontSize = container.dataset.pfcourseSize;
      box.classList.remove("pfcourse-math-scrolls");
    });
    // Inline formulas: their box is at most the line's width, so measure against the line.
    var widths = boxes.map(function (box) {
      var w = mathWidths(box);
      if (w && box.matches("span.math")) {
        // ... less the punctuation bound to it, which shares its line.
        var group = box.parentElement.classList.contains("pfcourse-nobreak") ? box.parentElement : null;
        var bound = group ? group.getBoundingClientRect().width - w.room : 0;
        var line = (group || box).parentElement.closest("p, li, dd, dt, td, th, div") || box.parentElement;
        w.room = Math.min(w.room, (line.clientWidth || w.room) - bound);
      }
      return w;
    });
    boxes.forEach(function (box, i) {
      var w = widths[i];
      if (!w || w.room <= 0 || w.need <= w.room + 0.5) { return; }
      var container = box.matches("mjx-container") ? box : box.querySelector("mjx-container");
      var scale = (w.room - 1) / w.need;
      if (scale >= MIN_SCALE) {
        var base = parseFloat(container.dataset.pfcourseSize) || 100;
        container.style.fontSize = (Math.floor(base * scale * 10) / 10) + "%";
      } else if (box.matches("span.math")) {
        box.classList.add("pfcourse-math-scrolls");
      }
    });
  }

  function markScrollers(root) {
    // A box that no longer scrolls (a formula that fits at this width) loses its fade.
    root.querySelectorAll(".pfcourse-more-right, .pfcourse-more-left").forEach(function (box) {
      if (!box.matches(SCROLLERS)) { box.classList.remove("pfcourse-more-right", "pfcourse-more-left"); }
    });
    root.querySelectorAll(SCROLLERS).forEach(function (box) {
      if (!box.dataset.pfcourseCue) {
        box.dataset.pfcourseCue = "1";
        box.addEventListener("scroll", function () { cue(box); }, {passive: true});
      }
      cue(box);
    });
  }

  function cue(box) {
    var hidden = box.scrollWidth - box.clientWidth;
    box.classList.toggle("pfcourse-more-right", hidden > 1 && box.scrollLeft < hidden - 1);
    box.classList.toggle("pfcourse-more-left", hidden > 1 && box.scrollLeft > 1);
  }

  function layout() {
    var root = document.querySelector("main") || document.body;
    fitFormulas(root);
    markScrollers(root);
    document.documentElement.dataset.pfcourseLayout = String(window.innerWidth);
  }

  var pending = null;
  function relayout() {
    if (pending !== null) { cancelAnimationFrame(pending); }
    delete document.documentElement.dataset.pfcourseLayout;
    pending = requestAnimationFrame(function () { pending = null; layout(); });
  }

  function start() {
    var root = document.querySelector("main") || document.body;
    bindPunctuation(root);
    layout();
    window.addEventListener("resize", relayout);
    // A folded block (an evidence block, a solution, hidden code) lays out its content when opened.
    document.addEventListener("toggle", relayout, true);
    // Widths change after this first pass when a folded block opens, an image or a web font
    // (MathJax's) arrives: the page's column and every formula are watched.
    if (window.ResizeObserver) {
      var watch = new ResizeObserver(relayout);
      watch.observe(root);
      root.querySelectorAll("article, mjx-math, span.math, " + SCROLLERS).forEach(function (el) { watch.observe(el); });
    }
    if (document.fonts) {
      document.fonts.addEventListener("loadingdone", relayout);
      document.fonts.ready.then(relayout);
    }
  }

  function whenTypeset(then) {
    var waited = 0;
    (function poll() {
      var mj = window.MathJax;
      if (!document.querySelector(".math")) { then(); return; }
      if (mj && mj.startup && mj.startup.promise) { mj.startup.promise.then(then, then); return; }
      waited += 50;
      if (waited > 60000) { then(); return; }  // no MathJax: scroll cues still apply
      setTimeout(poll, 50);
    })();
  }

  function begin() { whenTypeset(start); }
  if (document.readyState === "loading") { document.addEventListener("DOMContentLoaded", begin); } else { begin(); }
})();
