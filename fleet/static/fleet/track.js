// One vessel's track for a time range (issue 9 §2, §3; issue 18 §3): the server-simplified
// track with its gaps as breaks, arrows and UTC times along it (track_marks.js), the nearest
// fix on a click on or near it, and a plot per channel under the map (min–max band and mean
// line from /series/), their axes aligned and one cursor shared. Hovering a plot marks that
// moment on the map; clicking the track marks it on the plots. The first range is the
// vessel's last run of reports (the server's lastStretch), not a fixed 24 h.
(function () {
  "use strict";
  var S = window.Shoreside;
  var el = S.el;
  var RANGES = { "6h": 6 * 3600, "24h": 24 * 3600, "7d": 7 * 24 * 3600 };
  var LAST = "last"; // the vessel's last run of reports, from the page config
  var CLICK_PX = 10; // a click this near the drawn track picks a fix
  var MAX_POINTS = 2000;
  var MAX_BUCKETS = 1000;
  var PLOT_HEIGHT = 170;
  var COLOURS = ["#1565c0", "#2e7d32", "#6a1b9a", "#ef6c00", "#00838f", "#ad1457", "#4e342e"];
  var MARK_COLOUR = "#ff6f00";

  function iso(date) { return date.toISOString().replace(/\.\d{3}Z$/, "Z"); }
  // The range inputs are text in UTC ("2026-11-28 05:30", as the site writes times): the
  // browser's time zone and date format never enter.
  var UTC_INPUT = /^\s*(\d{4})-(\d{2})-(\d{2})[ T]+(\d{1,2}):(\d{2})(?::(\d{2}))?\s*(?:Z|UTC)?\s*$/i;
  function toInput(date) { return date.toISOString().slice(0, 16).replace("T", " "); }
  function fromInput(value) {
    var m = UTC_INPUT.exec(value || "");
    if (!m) { return null; }
    var f = m.slice(1).map(function (v) { return v === undefined ? 0 : parseInt(v, 10); });
    var d = new Date(Date.UTC(f[0], f[1] - 1, f[2], f[3], f[4], f[5]));
    // Date.UTC rolls 2026-02-30 over into March: only a real date and time is taken.
    var real = d.getUTCFullYear() === f[0] && d.getUTCMonth() === f[1] - 1 && d.getUTCDate() === f[2] &&
      d.getUTCHours() === f[3] && d.getUTCMinutes() === f[4];
    return real ? d : null;
  }

  function TrackPage(map, cfg) {
    this.map = map;
    this.cfg = cfg;
    this.trackLayer = L.layerGroup().addTo(map);
    this.timeMarker = L.marker([0, 0], {
      interactive: false, keyboard: false, zIndexOffset: 1000,
      icon: L.divIcon({ className: "time-marker", html: '<span class="time-marker-label"></span>', iconSize: [14, 14], iconAnchor: [7, 7] }),
    });
    this.points = [];
    this.plots = [];
    this.markedT = null;
    this.bar = document.getElementById("range-bar");
    this.bindRange();
    this.bindMap();
    var params = new URLSearchParams(location.search);
    var from = params.get("from") && new Date(params.get("from"));
    var to = params.get("to") && new Date(params.get("to"));
    if (from && to && !isNaN(from) && !isNaN(to)) { this.setRange(null, from, to); }
    else { this.setPreset(this.known(params.get("range")) ? params.get("range") : this.bar.dataset.default); }
    var self = this, plots = document.getElementById("plots");
    // The plots follow the column's width: a window resize, and the scroll bar that the
    // plots themselves bring when they make the page taller.
    if (window.ResizeObserver) { new ResizeObserver(function () { self.resizePlots(); }).observe(plots); }
    else { window.addEventListener("resize", function () { self.resizePlots(); }); }
  }

  TrackPage.prototype.known = function (name) {
    return name === LAST ? !!this.cfg.lastStretch : !!RANGES[name];
  };

  TrackPage.prototype.bindRange = function () {
    var self = this;
    this.bar.querySelectorAll("[data-range]").forEach(function (b) {
      b.addEventListener("click", function () { self.setPreset(b.dataset.range); });
    });
    document.getElementById("range-apply").addEventListener("click", function () {
      var from = fromInput(document.getElementById("range-from").value);
      var to = fromInput(document.getElementById("range-to").value);
      if (!from || !to || from >= to) {
        self.summary("Pick a “from” before the “to” (UTC).", true);
        return;
      }
      self.setRange(null, from, to);
    });
    ["range-from", "range-to"].forEach(function (id) {
      document.getElementById(id).addEventListener("keydown", function (e) {
        if (e.key === "Enter") { document.getElementById("range-apply").click(); }
      });
    });
  };

  TrackPage.prototype.setPreset = function (name) {
    if (name === LAST) {
      var last = this.cfg.lastStretch;
      this.setRange(LAST, new Date(last.from), new Date(last.to));
      return;
    }
    var to = new Date();
    this.setRange(name, new Date(to.getTime() - RANGES[name] * 1000), to);
  };

  TrackPage.prototype.setRange = function (preset, from, to) {
    this.preset = preset;
    this.from = from;
    this.to = to;
    this.bar.querySelectorAll("[data-range]").forEach(function (b) {
      b.classList.toggle("active", b.dataset.range === preset);
    });
    document.getElementById("range-from").value = toInput(from);
    document.getElementById("range-to").value = toInput(to);
    var query = preset ? "?range=" + preset : "?from=" + iso(from) + "&to=" + iso(to);
    history.replaceState(null, "", this.cfg.pageUrl + query);
    var span = "from=" + encodeURIComponent(iso(from)) + "&to=" + encodeURIComponent(iso(to));
    var base = this.cfg.exportUrl + "?" + span + "&format=";
    ["csv", "geojson", "gpx"].forEach(function (f) { document.getElementById("export-" + f).href = base + f; });
    this.load(span);
  };

  TrackPage.prototype.summary = function (text, error) {
    var box = document.getElementById("track-summary");
    box.textContent = text;
    box.classList.toggle("errornote", !!error);
  };

  TrackPage.prototype.load = function (span) {
    var self = this;
    var token = (this.loadToken = {});
    this.summary("Loading…");
    var plotsBox = document.getElementById("plots");
    var buckets = Math.min(MAX_BUCKETS, Math.max(100, plotsBox.clientWidth || 800));
    var track = S.getJSON(this.cfg.trackUrl + "?" + span + "&max_points=" + MAX_POINTS).then(answer);
    var series = S.getJSON(this.cfg.seriesUrl + "?" + span + "&buckets=" + buckets).then(answer);
    Promise.all([track, series])
      .then(function (res) {
        if (token !== self.loadToken) { return; }  // an older range answering late
        self.drawTrack(res[0]);
        self.drawPlots(res[1]);
      })
      .catch(function (err) {
        if (token === self.loadToken) { self.summary("Could not load the track: " + err.message, true); }
      });
  };

  function answer(r) {
    if (!r.ok) { throw new Error("HTTP " + r.status); }
    return r.json();
  }

  // --- the map -----------------------------------------------------------------------------

  TrackPage.prototype.drawTrack = function (collection) {
    var self = this;
    this.trackLayer.clearLayers();
    this.map.removeLayer(this.timeMarker);
    this.points = [];
    var feature = (collection.features || [])[0];
    var props = (feature && feature.properties) || {};
    var segments = (feature && feature.geometry && feature.geometry.coordinates) || [];
    var times = props.times || [];
    segments.forEach(function (seg, i) {
      seg.forEach(function (c, j) {
        self.points.push({ lat: c[1], lon: c[0], t: times[i] ? times[i][j] : null, seg: i });
      });
    });
    this.gapS = props.gap_s || null;
    var text = (props.fixes || 0) + " fixes in range, " + (props.points || this.points.length) + " points drawn";
    if (segments.length > 1) {
      text += ", " + segments.length + " stretches (reporting gaps over " + S.fmtDuration(props.gap_s) + " are breaks)";
    }
    this.summary(this.points.length ? text + "." : "No fixes in this range.");
    if (!this.points.length) { return; }
    // Not clickable itself: a click within CLICK_PX of it picks (bindMap), an easier target.
    var line = L.geoJSON(feature, { interactive: false, style: { color: "#1565c0", weight: 3, opacity: 0.9 } }).addTo(this.trackLayer);
    new S.TrackMarks(this.points).addTo(this.trackLayer);
    var first = this.points[0], last = this.points[this.points.length - 1];
    L.circleMarker([first.lat, first.lon], { radius: 6, color: "#2e7d32", fillOpacity: 0.9 })
      .bindTooltip("start " + S.fmtTime(first.t)).addTo(this.trackLayer);
    L.circleMarker([last.lat, last.lon], { radius: 6, color: "#c62828", fillOpacity: 0.9 })
      .bindTooltip("end " + S.fmtTime(last.t)).addTo(this.trackLayer);
    // No zoom animation: a new range is drawn at once, and a click lands where it shows.
    this.map.fitBounds(line.getBounds().pad(0.05), { maxZoom: 16, animate: false });
  };

  // A click within CLICK_PX of the drawn track picks the fix there; the pointer says where
  // a click would.
  TrackPage.prototype.bindMap = function () {
    var self = this, map = this.map, box = map.getContainer();
    map.on("click", function (e) {
      var hit = S.nearestOnTrack(map, self.points, e.layerPoint, CLICK_PX);
      if (hit && hit.t !== null) { self.trackClicked(hit); }
    });
    map.on("mousemove", function (e) {
      L.DomUtil[S.nearestOnTrack(map, self.points, e.layerPoint, CLICK_PX) ? "addClass" : "removeClass"](box, "near-track");
    });
  };

  // The point of the track under the click (its time along the drawn line), then the
  // server's fix nearest that time: its details in a popup, its moment on the plots.
  TrackPage.prototype.trackClicked = function (hit) {
    var self = this, map = this.map, latlng = L.latLng(hit.lat, hit.lon);
    this.markTime(hit.t);
    S.getJSON(this.cfg.nearestUrl + "?time=" + encodeURIComponent(new Date(Math.round(hit.t * 1000)).toISOString()))
      .then(answer)
      .then(function (fix) {
        L.popup({ maxWidth: 340, maxHeight: 260, keepInView: true, autoPanPadding: [12, 12] }).setLatLng([fix.lat, fix.lon]).setContent(self.fixTable(fix)).openOn(map);
        self.markTime(Date.parse(fix.time) / 1000);
      })
      .catch(function (err) { L.popup().setLatLng(latlng).setContent("No fix: " + err.message).openOn(map); });
  };

  TrackPage.prototype.fixTable = function (fix) {
    var channels = this.cfg.channels;
    function label(key) { return S.channelLabel(key, channels); }
    var rows = [
      ["Time", S.fmtTime(fix.time)],
      ["Position", S.positionEl(fix.lat, fix.lon)],
      ["Speed", S.fmtSpeed(fix.speed_mps)],
      ["Heading", S.fmtHeading(fix.heading_deg)],
      [label("battery_v"), S.fmtReading("battery_v", fix.battery_v, channels)],
    ];
    var readings = fix.readings || {};
    S.readingKeys(readings, channels).forEach(function (k) { rows.push([label(k), S.fmtReading(k, readings[k], channels)]); });
    var table = el("table", {}, rows.map(function (r) {
      return el("tr", {}, [el("th", { text: r[0] }), typeof r[1] === "string" ? el("td", { text: r[1] }) : el("td", {}, [r[1]])]);
    }));
    return el("div", { class: "fix-popup" }, [table]);
  };

  // Where the vessel was at time t: between the two drawn points around it (within a stretch).
  TrackPage.prototype.positionAt = function (t) {
    var pts = this.points, lo = 0, hi = pts.length - 1;
    if (!pts.length || t < pts[0].t || t > pts[hi].t) { return null; }
    while (hi - lo > 1) {
      var mid = (lo + hi) >> 1;
      if (pts[mid].t <= t) { lo = mid; } else { hi = mid; }
    }
    var a = pts[lo], b = pts[hi];
    if (a.seg !== b.seg || b.t === a.t) { return t - a.t < b.t - t ? [a.lat, a.lon] : [b.lat, b.lon]; }
    var f = (t - a.t) / (b.t - a.t);
    return [a.lat + (b.lat - a.lat) * f, a.lon + (b.lon - a.lon) * f];
  };

  TrackPage.prototype.showMoment = function (t) {
    var at = t === null ? null : this.positionAt(t);
    if (!at) { this.map.removeLayer(this.timeMarker); return; }
    this.timeMarker.setLatLng(at);
    if (!this.map.hasLayer(this.timeMarker)) { this.timeMarker.addTo(this.map); }
    var node = this.timeMarker.getElement();
    if (node) {
      node.setAttribute("data-time", String(t));
      node.title = S.fmtTime(t);
      node.firstChild.textContent = new Date(t * 1000).toISOString().slice(11, 19);
    }
  };

  // --- the plots ---------------------------------------------------------------------------

  TrackPage.prototype.markTime = function (t) {
    this.markedT = t;
    // A cursor set from code is not passed on by uPlot's sync: each plot's is set (the same
    // x on each, as their axes line up), and the map's marker follows.
    this.plots.forEach(function (u) {
      u.redraw(false);
      var left = u.valToPos(t, "x");
      if (left >= 0 && left <= u.bbox.width / devicePixelRatio) { u.setCursor({ left: left, top: u.bbox.height / devicePixelRatio / 2 }); }
    });
  };

  TrackPage.prototype.drawPlots = function (data) {
    var self = this, box = document.getElementById("plots");
    this.plots.forEach(function (u) { u.destroy(); });
    this.plots = [];
    box.innerHTML = "";
    var keys = Object.keys(data.channels || {});
    // Battery first, then the channels by label.
    keys.sort(function (a, b) {
      if (a === "battery_v" || b === "battery_v") { return a === "battery_v" ? -1 : 1; }
      return self.label(a, data).localeCompare(self.label(b, data));
    });
    if (!keys.length || !(data.t || []).length) {
      box.appendChild(el("p", { class: "muted", text: "No sensor data in this range." }));
      return;
    }
    // Every plot's value axis as wide as the widest: the plotting areas, and so the time
    // axes and the shared cursor, line up.
    var axis = { px: 0 };
    // Empty buckets between sparse fixes are joined; only a reporting gap (the track's gap_s)
    // breaks the line, as on the map.
    function gaps(u, sidx, idx0, idx1, nullGaps) {
      var pxPerS = u.bbox.width / (u.scales.x.max - u.scales.x.min);
      return nullGaps.filter(function (g) { return !self.gapS || (g[1] - g[0]) / pxPerS > self.gapS; });
    }
    keys.forEach(function (key, i) {
      var ch = data.channels[key];
      var colour = COLOURS[i % COLOURS.length];
      var known = self.cfg.channels[key];
      var unit = known ? known.unit : ch.unit || "";
      var title = self.label(key, data) + (unit ? " (" + unit + ")" : "");
      var holder = el("div", { class: "plot", "data-key": key }, [el("p", { class: "plot-title", text: title })]);
      box.appendChild(holder);
      var states = known && known.states;
      holder.setAttribute("data-plot", states ? "steps" : "line");
      var opts = {
        width: box.clientWidth || 800,
        height: PLOT_HEIGHT,
        tzDate: function (ts) { return uPlot.tzDate(new Date(ts * 1000), "Etc/UTC"); },
        cursor: { sync: { key: "track" }, drag: { x: false, y: false }, y: false, dataIdx: nearestData(self.gapS) },
        legend: { show: true },
        scales: {
          x: { time: true, range: [self.from.getTime() / 1000, self.to.getTime() / 1000] },
          y: { range: states ? stateRange(states) : yRange(known) },
        },
        series: states ? stateSeries(states, colour, gaps) : [
          { label: "time (UTC)", value: function (u, v) { return v === null || v === undefined ? "–" : S.fmtTime(v); } },
          { label: "min", stroke: colour + "66", width: 1, value: fmt(unit), gaps: gaps },
          { label: "max", stroke: colour + "66", width: 1, value: fmt(unit), gaps: gaps },
          { label: "mean", stroke: colour, width: 1.5, value: fmt(unit), gaps: gaps },
        ],
        bands: [{ series: [2, 1], fill: colour + "33" }],
        axes: [{ values: timeLabels, space: 70 }, Object.assign(states ? stateAxis(states, ch) : {}, { size: sharedSize(axis) })],
        hooks: {
          setCursor: [function (u) {
            var idx = u.cursor.idx;
            self.showMoment(idx === null || idx === undefined ? null : u.posToVal(u.cursor.left, "x"));
          }],
          draw: [function (u) { self.drawMark(u); }],
        },
      };
      // A state has no mean: its plot is the bucket's lowest and highest state as steps, the
      // band between them where it changed within the bucket.
      var columns = states ? [data.t, ch.min, ch.max] : [data.t, ch.min, ch.max, ch.mean];
      self.plots.push(new uPlot(opts, columns, holder));
    });
    // The first plots were sized before the last ones measured their labels.
    this.resizePlots();
  };

  // The legend shows the nearest bucket with data (sparse fixes leave most buckets empty),
  // but never across a reporting gap: there the value is unknown.
  function nearestData(gapS) {
    var limit = gapS || Infinity;
    function has(v) { return v !== null && v !== undefined; }
    return function (u, sidx, idx) {
      var col = u.data[sidx], t = u.data[0];
      if (sidx === 0 || has(col[idx])) { return idx; }
      for (var k = 1; k < col.length; k++) {
        var lo = idx - k, hi = idx + k;
        var loOk = lo >= 0 && t[idx] - t[lo] <= limit, hiOk = hi < col.length && t[hi] - t[idx] <= limit;
        if (!loOk && !hiOk) { break; }
        if (loOk && has(col[lo])) { return lo; }
        if (hiOk && has(col[hi])) { return hi; }
      }
      return idx;
    };
  }

  // The page's SensorChannel labels first (the same as the fleet map's), then the series'.
  TrackPage.prototype.label = function (key, data) {
    var known = this.cfg.channels[key], ch = (data && data.channels[key]) || {};
    return (known && known.label) || ch.label || key;
  };

  // The moment clicked on the track, as a vertical line on every plot.
  TrackPage.prototype.drawMark = function (u) {
    if (this.markedT === null) { return; }
    var x = Math.round(u.valToPos(this.markedT, "x", true));
    if (x < u.bbox.left || x > u.bbox.left + u.bbox.width) { return; }
    var ctx = u.ctx;
    ctx.save();
    ctx.strokeStyle = MARK_COLOUR;
    ctx.lineWidth = 2 * devicePixelRatio;
    ctx.beginPath();
    ctx.moveTo(x, u.bbox.top);
    ctx.lineTo(x, u.bbox.top + u.bbox.height);
    ctx.stroke();
    ctx.restore();
  };

  TrackPage.prototype.resizePlots = function () {
    var width = document.getElementById("plots").clientWidth;
    this.plots.forEach(function (u) {
      if (u.width !== width) { u.setSize({ width: width, height: PLOT_HEIGHT }); }
      u.redraw(false, true); // and the value axes to the shared width
    });
  };

  // A value axis's width: its widest label (as uPlot measures them) and the widest of the
  // other plots' (shared.px).
  function sharedSize(shared) {
    return function (u, values, axisIdx) {
      var axis = u.axes[axisIdx], size = axis.ticks.size + axis.gap, widest = 0;
      if (values && values.length) {
        u.ctx.font = axis.font[0];
        values.forEach(function (v) {
          if (v !== null && v !== undefined) { widest = Math.max(widest, u.ctx.measureText(String(v)).width / devicePixelRatio); }
        });
      }
      shared.px = Math.max(shared.px, Math.ceil(size + widest + 4));
      return shared.px;
    };
  }

  // The channel's plot bounds from SensorChannel when it has them, widened to the data.
  function yRange(channel) {
    return function (u, dataMin, dataMax) {
      var lo = channel && channel.min !== null && channel.min !== undefined ? Math.min(channel.min, dataMin) : dataMin;
      var hi = channel && channel.max !== null && channel.max !== undefined ? Math.max(channel.max, dataMax) : dataMax;
      if (lo === null || hi === null) { return [0, 1]; }
      if (hi - lo < 1e-9) { var pad = Math.abs(hi) * 0.01 || 1; lo -= pad; hi += pad; }
      return uPlot.rangeNum(lo, hi, 0.1, true);
    };
  }

  // 24-hour UTC clock times, with the date under the first tick of each day.
  function timeLabels(u, splits) {
    var lastDay = null;
    return splits.map(function (t) {
      var iso = new Date(t * 1000).toISOString(), day = iso.slice(5, 10), label = iso.slice(11, 16);
      if (day !== lastDay) { label += "\n" + day; lastDay = day; }
      return label;
    });
  }

  // State channels (mode, armed): steps between named values, the names on the axis and in
  // the legend; a line between HOLD (4) and GUIDED (15) would pass through modes never set.
  function stateSeries(states, colour, gaps) {
    var steps = uPlot.paths.stepped({ align: 1 });
    function named(u, v) {
      if (v === null || v === undefined) { return "–"; }
      return Object.prototype.hasOwnProperty.call(states, String(v)) ? states[String(v)] : String(v);
    }
    return [
      { label: "time (UTC)", value: function (u, v) { return v === null || v === undefined ? "–" : S.fmtTime(v); } },
      { label: "min", stroke: colour, width: 2, paths: steps, value: named, gaps: gaps },
      { label: "max", stroke: colour, width: 2, paths: steps, value: named, gaps: gaps },
    ];
  }

  function stateValues(states) {
    return Object.keys(states).map(Number).sort(function (a, b) { return a - b; });
  }

  // A two-state channel (armed) shows both rows; a longer table (mode) the span of the states
  // seen; half a step of room either side.
  function stateRange(states) {
    return function (u, dataMin, dataMax) {
      var values = stateValues(states), all = values.length <= 2 || dataMin === null;
      var lo = all ? values[0] : dataMin, hi = all ? values[values.length - 1] : dataMax;
      return [lo - 0.5, Math.max(hi, lo + 1) + 0.5];
    };
  }

  // Ticks at the named values seen in the data (all of them for a two-state channel), by name.
  function stateAxis(states) {
    return {
      splits: function (u) {
        var seen = {};
        [u.data[1], u.data[2]].forEach(function (col) {
          (col || []).forEach(function (v) { if (v !== null && v !== undefined) { seen[v] = true; } });
        });
        var values = stateValues(states);
        return values.filter(function (v) { return values.length <= 2 || seen[v]; });
      },
      values: function (u, splits) { return splits.map(function (v) { return states[String(v)] || String(v); }); },
    };
  }

  function fmt(unit) {
    return function (u, v) { return v === null || v === undefined ? "–" : S.fmtValue(v, unit); };
  }

  window.ShoresideTrackMap = function (map) {
    // Quarter zoom steps when fitting a range: the track fills the map instead of a quarter
    // of it, with room for its arrows and times.
    map.options.zoomSnap = 0.25;
    S.baseMap(map);
    window.shoresideTrack = new TrackPage(map, S.json("track-config"));
  };
})();
