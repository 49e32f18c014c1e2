/* The product's pages: charts from the JSON the page carries (#page-data), drawn with uPlot.
 * Drag across a chart to zoom in, double-click to zoom out; the legend shows the values under the
 * cursor. Nothing is fetched: every number comes from the page. */
(function () {
  "use strict";

  var drawn = [];  // every chart of the page, in order (window.enginePages.charts: for a look from the console)
  window.enginePages = { charts: drawn };
  var COLOURS = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2", "#17becf"];

  function element(tag, attributes, text) {
    var node = document.createElement(tag);
    Object.keys(attributes || {}).forEach(function (key) { node.setAttribute(key, attributes[key]); });
    if (text !== undefined) { node.textContent = text; }
    return node;
  }

  function panel(parent, title, id) {
    var box = element("div", { "class": "chart", id: id });
    box.appendChild(element("h3", {}, title));
    parent.appendChild(box);
    return box;
  }

  function width(node) {
    return Math.max(320, Math.min(1100, (node.clientWidth || 900) - 10));
  }

  function number(value, digits) {
    return value === null || value === undefined ? "-" : Number(value).toPrecision(digits || 4);
  }

  function ticks(u, values) {
    return values.map(function (v) {
      if (v === null || v === undefined) { return ""; }
      var a = Math.abs(v);
      return a !== 0 && (a < 0.01 || a >= 1e5) ? v.toExponential(0) : String(Number(v.toPrecision(6)));
    });
  }

  function chart(box, series, data, options) {
    var x = { label: options.xLabel };
    if (options.integerX) { x.incrs = [1]; }
    var opts = Object.assign({
      width: width(box),
      height: 260,
      scales: { x: { time: false } },
      series: series,
      axes: [x, { label: options.yLabel, size: 70, values: ticks }],
      cursor: { drag: { x: true, y: false } }
    }, options.extra || {});
    if (options.logY) { opts.scales.y = { distr: 3 }; }
    var plot = new uPlot(opts, data, box);
    drawn.push(plot);
    return plot;
  }

  function balance(parent, diagnosis) {
    var b = diagnosis.cylinder_balance;
    if (!b || !b.relative) { return; }
    var n = b.relative.length;
    var xs = [], ys = [], lo = [], hi = [], warn = [], alarm = [];
    for (var i = 0; i < n; i++) {
      var error = b.relative_standard_error ? b.relative_standard_error[i] : null;
      xs.push(i + 1);
      ys.push(b.relative[i]);
      lo.push(error === null || b.relative[i] === null ? null : b.relative[i] - error);
      hi.push(error === null || b.relative[i] === null ? null : b.relative[i] + error);
      warn.push(0.85);
      alarm.push(0.5);
    }
    var box = panel(parent, "Cylinder balance: each cylinder's strength against those firing alike (1 = healthy)",
      "chart-balance");
    chart(box, [
      { label: "cylinder" },
      { label: "strength", stroke: COLOURS[0], fill: "rgba(31,119,180,0.35)",
        paths: uPlot.paths.bars({ size: [0.6, 80] }) },
      { label: "- 1 s.e.", stroke: "#555", width: 0, points: { show: true, size: 6 } },
      { label: "+ 1 s.e.", stroke: "#555", width: 0, points: { show: true, size: 6 } },
      { label: "warning below", stroke: "#e6a100", dash: [6, 4] },
      { label: "alarm below", stroke: "#c0392b", dash: [6, 4] }
    ], [xs, ys, lo, hi, warn, alarm], { xLabel: "cylinder", yLabel: "strength [-]", integerX: true,
      extra: { scales: { x: { time: false, range: [0.5, n + 0.5] }, y: { range: [Math.min(0, Math.min.apply(null, lo.filter(function (v) { return v !== null; }).concat([0]))), 1.4] } } } });
  }

  function comparisons(parent, diagnosis) {
    var channels = diagnosis.channels || {};
    Object.keys(channels).forEach(function (name, k) {
      var c = channels[name];
      if (!c.orders || !c.orders.length) { return; }
      var box = panel(parent, name + ": measured against predicted orders [" + c.unit + "]", "chart-channel-" + k);
      box.appendChild(element("p", { "class": "basis" }, "Predicted from: " + c.basis));
      // amplitudes at or below a billionth of the largest are zeros the model predicts (nothing to draw on a
      // logarithmic axis)
      var largest = Math.max.apply(null, c.measured_amplitude.concat(c.predicted_amplitude).filter(isFinite));
      var positive = function (values) {
        return values.map(function (v) { return v > 1e-9 * largest ? v : null; });
      };
      chart(box, [
        { label: "order" },
        { label: "measured", stroke: COLOURS[0], points: { show: true, size: 7 }, width: 1 },
        { label: "predicted", stroke: COLOURS[1], points: { show: true, size: 7 }, width: 1, dash: [4, 4] }
      ], [c.orders, positive(c.measured_amplitude), positive(c.predicted_amplitude)],
      { xLabel: "order [-]", yLabel: "amplitude [" + c.unit + "]", logY: true, integerX: true });
    });
  }

  function spectra(parent, spectrum) {
    if (!spectrum || !spectrum.channels) { return; }
    Object.keys(spectrum.channels).forEach(function (name, k) {
      var s = spectrum.channels[name];
      if (!s.orders || !s.orders.length) { return; }
      var box = panel(parent, name + ": measured order spectrum [" + s.unit + "]", "chart-spectrum-" + k);
      chart(box, [
        { label: "order" },
        { label: "amplitude", stroke: COLOURS[2], points: { show: true, size: 4 }, width: 1 }
      ], [s.orders, s.amplitude.map(function (v) { return v > 0 ? v : null; })],
      { xLabel: "order [-]", yLabel: "amplitude [" + s.unit + "]", logY: true });
    });
  }

  function tables(parent, diagnosis) {
    var rms = diagnosis.velocity_rms || {};
    var names = Object.keys(rms);
    if (!names.length) { return; }
    var table = element("table", { "class": "values", id: "velocity-rms" });
    var head = element("tr");
    ["sensor", "rms velocity [mm/s]", "standard error", "zone"].forEach(function (t) { head.appendChild(element("th", {}, t)); });
    table.appendChild(head);
    names.forEach(function (name) {
      var row = element("tr");
      [name, number(rms[name].value_mm_s), number(rms[name].standard_error_mm_s, 2), rms[name].zone || "-"]
        .forEach(function (t) { row.appendChild(element("td", {}, t)); });
      table.appendChild(row);
    });
    var box = element("div", { "class": "chart" });
    box.appendChild(element("h3", {}, "Vibration severity (rms velocity)"));
    box.appendChild(table);
    parent.appendChild(box);
  }

  function trends(parent, data) {
    var quantities = data.quantities || {};
    Object.keys(quantities).forEach(function (name, k) {
      var q = quantities[name];
      if (!q.points || !q.points.length) { return; }
      var xs = q.points.map(function (p) { return Date.parse(p.recorded_at) / 1000; });
      var ys = q.points.map(function (p) { return p.value; });
      var box = panel(parent, name + " [" + q.unit + "]" + (q.drift ? ": " + q.drift.summary : ""),
        "chart-trend-" + k);
      if (q.drift) { box.classList.add("drifting"); }
      // a day either side of the recordings (all of them at one time would give no span to draw)
      var first = Math.min.apply(null, xs), last = Math.max.apply(null, xs);
      var pad = Math.max(86400, 0.03 * (last - first));
      chart(box, [
        {},
        { label: name, stroke: q.drift ? COLOURS[1] : COLOURS[0], points: { show: true, size: 6 }, width: 1 }
      ], [xs, ys], { xLabel: "recording time (UTC)", yLabel: "[" + q.unit + "]",
        extra: { scales: { x: { time: true, range: [first - pad, last + pad] } },
          tzDate: function (ts) { return uPlot.tzDate(new Date(ts * 1e3), "Etc/UTC"); } } });
    });
  }

  function draw() {
    var source = document.getElementById("page-data");
    var parent = document.getElementById("charts");
    if (!source || !parent || typeof uPlot === "undefined") { return; }
    var data = JSON.parse(source.textContent);
    if (data.view === "recording") {
      balance(parent, data.diagnosis);
      comparisons(parent, data.diagnosis);
      spectra(parent, data.spectrum);
      tables(parent, data.diagnosis);
    } else if (data.view === "engine" && data.trend) {
      if (data.latest) { balance(parent, data.latest); }
      trends(parent, data.trend);
    }
    document.body.setAttribute("data-charts", String(parent.querySelectorAll(".uplot").length));
  }

  if (document.readyState === "loading") {
    document.addEventListener("DOMContentLoaded", draw);
  } else {
    draw();
  }
}());
