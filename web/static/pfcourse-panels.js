/* pfcourse: the HTML book's control panels, without a kernel (issue 19).
   Each .pfcourse-panel carries the figures of a grid of control values (made when the
   chapter executed, pfcourse/figures/static_panel.py) as JSON data; moving a control shows
   the figure of the new grid point.  Image number = sum of (control's index x its stride). */
(function () {
  "use strict";
  function setUp(panel) {
    var data = JSON.parse(panel.querySelector("script.pfcourse-panel-data").textContent);
    var img = panel.querySelector("img.pfcourse-panel-figure");
    var text = panel.querySelector("pre.pfcourse-panel-text");
    var inputs = data.controls.map(function (name, k) {
      return data.enabled[k] ? panel.querySelector('[name="' + name + '"]') : null;
    });
    function update() {
      var index = 0;
      inputs.forEach(function (input, k) {
        if (!input) { return; }
        var i = parseInt(input.value, 10);
        index += i * data.strides[k];
        var readout = input.parentElement.querySelector("output");
        if (readout) { readout.textContent = data.labels[k][i]; }
      });
      if (String(index) !== panel.dataset.current || !img.src) {
        img.src = data.images[index];
        if (text) { text.textContent = data.texts[index]; }
        panel.dataset.current = String(index);
      }
    }
    inputs.forEach(function (input) {
      if (input) { input.addEventListener("input", update); input.addEventListener("change", update); }
    });
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
