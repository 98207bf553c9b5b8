/* pfcourse: the HTML book's control panels, without a kernel (issues 19 and 33).
   Each .pfcourse-panel carries, as JSON data, the figures made when the chapter executed
   (pfcourse/figures/static_panel.py): every combination of its main controls' values, and
   each value of every other ("side") control with the rest at the values the page opens
   with.  Main grid: image number = sum of (control's index x its stride).  Side control k
   at value i: image data.side[k][i].  A combination that was not computed (a side control
   moved while another control is off its first value) shows the figure of the control moved
   last, with the others at their first values, and says so under the controls.
   Phones: a figure too wide to read scaled to a phone's column has a narrow copy (data.narrow,
   pfcourse/narrow_figures.py), shown while the window matches data.narrowMedia. */
(function () {
  "use strict";
  function setUp(panel) {
    var data = JSON.parse(panel.querySelector("script.pfcourse-panel-data").textContent);
    var img = panel.querySelector("img.pfcourse-panel-figure");
    var text = panel.querySelector("pre.pfcourse-panel-text");
    var nearest = panel.querySelector("p.pfcourse-panel-nearest");
    var main = data.main || data.controls.map(function () { return true; });
    var defaults = data.defaults || data.controls.map(function () { return 0; });
    var lastMoved = null;
    var narrow = data.narrow && window.matchMedia ? window.matchMedia(data.narrowMedia) : null;
    function source(image) {
      return (narrow && narrow.matches && data.narrow[image]) || data.images[image];
    }
    var inputs = data.controls.map(function (name, k) {
      return data.enabled[k] ? panel.querySelector('[name="' + name + '"]') : null;
    });
    function indices() {
      return inputs.map(function (input, k) { return input ? parseInt(input.value, 10) : defaults[k]; });
    }
    function choose(idx) {
      var moved = [];
      idx.forEach(function (i, k) { if (!main[k] && i !== defaults[k]) { moved.push(k); } });
      var gridIndex = idx.reduce(function (sum, i, k) { return main[k] ? sum + i * data.strides[k] : sum; }, 0);
      if (moved.length === 0) { return {image: gridIndex, shown: null}; }
      var s = moved.indexOf(lastMoved) >= 0 ? lastMoved : moved[moved.length - 1];
      var others = [];
      idx.forEach(function (i, k) {
        if (k !== s && i !== defaults[k]) { others.push(data.descriptions[k] + " = " + data.labels[k][defaults[k]]); }
      });
      return {image: data.side[String(s)][idx[s]], shown: s, others: others};
    }
    function update() {
      var idx = indices();
      inputs.forEach(function (input, k) {
        if (!input) { return; }
        var readout = input.parentElement.querySelector("output");
        if (readout) { readout.textContent = data.labels[k][idx[k]]; }
      });
      var pick = choose(idx);
      if (nearest) {
        if (pick.others && pick.others.length) {
          nearest.textContent = "This combination was not computed for the page: the figure shows " +
            data.descriptions[pick.shown] + " = " + data.labels[pick.shown][idx[pick.shown]] + " with " +
            pick.others.join(", ") + " (the values the panel opens with). Every combination is live in JupyterLab.";
          nearest.hidden = false;
        } else {
          nearest.hidden = true;
        }
      }
      if (String(pick.image) !== panel.dataset.current || !img.src || img.src !== source(pick.image)) {
        img.src = source(pick.image);
        if (text) { text.textContent = data.texts[pick.image]; }
        panel.dataset.current = String(pick.image);
      }
    }
    inputs.forEach(function (input, k) {
      if (!input) { return; }
      function moved() { lastMoved = k; update(); }
      input.addEventListener("input", moved);
      input.addEventListener("change", moved);
    });
    if (narrow) {  // the window crossed the phone width: the other copy of the figure
      if (narrow.addEventListener) { narrow.addEventListener("change", update); } else { narrow.addListener(update); }
    }
    update();
    panel.classList.add("pfcourse-panel-ready");
  }
  function setUpAll() {
    document.querySelectorAll(".pfcourse-panel:not(.pfcourse-panel-ready)").forEach(setUp);
  }
  if (document.readyState === "loading") {
    document.addEventListener("DOMContentLoaded", setUpAll);
  } else {
    setUpAll();
  }
})();
