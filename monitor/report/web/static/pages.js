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
    if (options.xNames) {  // a V engine's A1 .. B6 at the integer places 1 .. n
      x.values = function (u, splits) {
        return splits.map(function (v) { return options.xNames[v - 1] === undefined ? "" : options.xNames[v - 1]; });
      };
    }
    var opts = Object.assign({
      width: width(box),
      height: options.height || 260,
      scales: { x: { time: false } },
      series: series,
      axes: [x, { label: options.yLabel, size: 70, values: ticks }],
      cursor: { drag: { x: true, y: false } }
    }, options.extra || {});
    if (options.logY) { opts.scales.y = Object.assign({ distr: 3 }, opts.scales.y || {}); }
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
    var box = panel(parent, "Cylinder balance: each cylinder's strength against those firing alike, on a V those of its own bank (1 = healthy)",
      "chart-balance");
    var names = b.names || null;  // a V engine's bank names; the legend says B3 where the axis does
    chart(box, [
      { label: "cylinder", value: function (u, v) { return names && v !== null && names[v - 1] !== undefined ? names[v - 1] : v; } },
      { label: "strength", stroke: COLOURS[0], fill: "rgba(31,119,180,0.35)",
        paths: uPlot.paths.bars({ size: [0.6, 80] }) },
      { label: "- 1 s.e.", stroke: "#555", width: 0, points: { show: true, size: 6 } },
      { label: "+ 1 s.e.", stroke: "#555", width: 0, points: { show: true, size: 6 } },
      { label: "warning below", stroke: "#e6a100", dash: [6, 4] },
      { label: "alarm below", stroke: "#c0392b", dash: [6, 4] }
    ], [xs, ys, lo, hi, warn, alarm], { xLabel: "cylinder", yLabel: "strength [-]", integerX: true,
      xNames: names,
      extra: { scales: { x: { time: false, range: [0.5, n + 0.5] }, y: { range: [Math.min(0, Math.min.apply(null, lo.filter(function (v) { return v !== null; }).concat([0]))), 1.4] } } } });
  }

  // A logarithmic axis cannot show zero, and the model's zeros come out near 1e-16 of the largest: so each
  // chart has a floor, the decade below the smallest amplitude within RANGE of the largest, and smaller
  // ones are drawn on it (a dashed line says where) with their own value in the legend, "below the floor".
  var RANGE = 1e-4;  // 80 dB: the depth a chart shows; below, a value is a zero for the eye

  function floorOf(columns) {
    var values = [].concat.apply([], columns).filter(function (v) { return v !== null && isFinite(v) && v > 0; });
    if (!values.length) { return 1e-12; }
    var largest = Math.max.apply(null, values);
    var shown = values.filter(function (v) { return v >= RANGE * largest; });
    return Math.pow(10, Math.ceil(Math.log10(Math.min.apply(null, shown))) - 1);
  }

  function floored(values, floor) {
    return values.map(function (v) { return v === null || !isFinite(v) ? null : Math.max(v, floor); });
  }

  function amplitudeSeries(label, raw, floor, style) {
    // the legend shows the value itself, not the floor it is drawn at
    return Object.assign({ label: label, value: function (u, v, s, i) {
      if (i === null || raw[i] === null || raw[i] === undefined) { return "--"; }
      return raw[i] < floor ? "below the floor " + number(floor, 1) + " (" + number(raw[i], 2) + ")"
        : number(raw[i]);
    } }, style);
  }

  function floorSeries(xs, floor) {
    return [{ label: "floor (smaller values drawn on it)", stroke: "#757575", width: 1, dash: [2, 4],
      points: { show: false }, value: function () { return number(floor, 1); } },
      xs.map(function () { return floor; })];
  }

  function logRange(floor) {
    // from just under the floor to the decade above the largest value
    return function (u, min, max) {
      return [floor / 2, Math.pow(10, Math.ceil(Math.log10(Math.max(max, floor) * 1.05)))];
    };
  }

  function comparisons(parent, diagnosis) {
    var channels = diagnosis.channels || {};
    Object.keys(channels).forEach(function (name, k) {
      var c = channels[name];
      if (!c.orders || !c.orders.length) { return; }
      var box = panel(parent, name + ": measured against predicted orders [" + c.unit + "]", "chart-channel-" + k);
      box.appendChild(element("p", { "class": "basis" }, "Predicted from: " + c.basis));
      var floor = floorOf([c.measured_amplitude, c.predicted_amplitude]);
      var below = floorSeries(c.orders, floor);
      chart(box, [
        { label: "order" },
        amplitudeSeries("measured", c.measured_amplitude, floor,
          { stroke: COLOURS[0], points: { show: true, size: 7 }, width: 1 }),
        amplitudeSeries("predicted", c.predicted_amplitude, floor,
          { stroke: COLOURS[1], points: { show: true, size: 7 }, width: 1, dash: [4, 4] }),
        below[0]
      ], [c.orders, floored(c.measured_amplitude, floor), floored(c.predicted_amplitude, floor), below[1]],
      { xLabel: "order [-]", yLabel: "amplitude [" + c.unit + "]", logY: true, integerX: true,
        extra: { scales: { x: { time: false }, y: { range: logRange(floor) } } } });
    });
  }

  function spectra(parent, spectrum) {
    if (!spectrum || !spectrum.channels) { return; }
    Object.keys(spectrum.channels).forEach(function (name, k) {
      var s = spectrum.channels[name];
      if (!s.orders || !s.orders.length) { return; }
      var box = panel(parent, name + ": measured order spectrum [" + s.unit + "]", "chart-spectrum-" + k);
      var floor = floorOf([s.amplitude]);
      var below = floorSeries(s.orders, floor);
      chart(box, [
        { label: "order" },
        amplitudeSeries("amplitude", s.amplitude, floor,
          { stroke: COLOURS[2], points: { show: true, size: 4 }, width: 1 }),
        below[0]
      ], [s.orders, floored(s.amplitude, floor), below[1]],
      { xLabel: "order [-]", yLabel: "amplitude [" + s.unit + "]", logY: true,
        extra: { scales: { x: { time: false }, y: { range: logRange(floor) } } } });
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

  // The engine's trend: a chart per group of quantities (the page's "groups", monitor/report/web/pages.py), one
  // series per quantity, one x per recording (in time order: recordings at the same time stay apart).
  function trendChart(box, trend, group) {
    var quantities = trend.quantities || {};
    var recordings = {}, order = [];
    group.quantities.forEach(function (name) {
      (quantities[name].points || []).forEach(function (p) {
        if (!(p.recording_id in recordings)) {
          recordings[p.recording_id] = { t: Date.parse(p.recorded_at) / 1000, id: p.recording_id };
          order.push(recordings[p.recording_id]);
        }
      });
    });
    if (!order.length) { return null; }
    order.sort(function (a, b) { return a.t - b.t || a.id - b.id; });
    var xs = order.map(function (r) { return r.t; });
    var series = [{}], data = [xs], palette = COLOURS.filter(function (c) { return c !== COLOURS[1]; });
    group.quantities.forEach(function (name, k) {
      var byRecording = {};
      (quantities[name].points || []).forEach(function (p) { byRecording[p.recording_id] = p.value; });
      var drifting = group.drifting.indexOf(name) >= 0;
      series.push({ label: name + (drifting ? " (drift)" : ""), spanGaps: true, points: { show: true, size: 6 },
        stroke: drifting ? COLOURS[1] : palette[k % palette.length], width: drifting ? 3 : 1 });
      data.push(order.map(function (r) { return r.id in byRecording ? byRecording[r.id] : null; }));
    });
    // a day either side of the recordings (all of them at one time would give no span to draw)
    var first = xs[0], last = xs[xs.length - 1];
    var pad = Math.max(86400, 0.03 * (last - first));
    return chart(box, series, data, { xLabel: "recording time (UTC)", yLabel: "[" + group.unit + "]",
      height: 220,
      extra: { scales: { x: { time: true, range: [first - pad, last + pad] } },
        tzDate: function (ts) { return uPlot.tzDate(new Date(ts * 1e3), "Etc/UTC"); } } });
  }

  function trends(parent, data) {
    (data.groups || []).filter(function (g) { return g.shown; }).forEach(function (group, k) {
      var title = group.title + (group.drifting.length ? ": drift in " + group.drifting.join(", ") : "");
      var box = panel(parent, title, "chart-trend-" + k);
      box.setAttribute("data-group", group.key);
      if (group.drifting.length) { box.classList.add("drifting"); }
      trendChart(box, data.trend, group);
    });
  }

  function chooser(data) {
    // the groups not shown, one at a time: the chosen one's chart replaces the last
    var select = document.getElementById("trend-choice"), box = document.getElementById("chart-choice");
    if (!select || !box) { return; }
    var plot = null;
    function show() {
      if (plot) { drawn.splice(drawn.indexOf(plot), 1); plot.destroy(); plot = null; }
      var group = (data.groups || []).filter(function (g) { return g.key === select.value; })[0];
      box.setAttribute("data-group", group ? group.key : "");
      if (group) { plot = trendChart(box, data.trend, group); }
      count();
    }
    select.addEventListener("change", show);
    show();
  }

  function count() {
    document.body.setAttribute("data-charts", String(document.querySelectorAll(".uplot").length));
  }

  function draw() {
    var source = document.getElementById("page-data");
    var parent = document.getElementById("charts");
    if (!source || !parent || typeof uPlot === "undefined") { return; }
    var data = JSON.parse(source.textContent);
    if (data.view === "recording" && data.diagnosis) {
      balance(parent, data.diagnosis);
      comparisons(parent, data.diagnosis);
      spectra(parent, data.spectrum);
      tables(parent, data.diagnosis);
    } else if (data.view === "engine" && data.trend) {
      if (data.latest) { balance(parent, data.latest); }
      trends(parent, data);
      chooser(data);
    }
    count();
  }

  if (document.readyState === "loading") {
    document.addEventListener("DOMContentLoaded", draw);
  } else {
    draw();
  }
}());
