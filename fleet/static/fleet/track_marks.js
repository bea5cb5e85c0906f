// The track view's marks along the track (issue 18 §3): arrows the way the vessel went and
// UTC times every N minutes, spaced on screen so they never pile up at any zoom; and the
// track's point nearest a click, within a few pixels. Plain Leaflet, no build step; the page
// (track.js) gives the drawn points: [{lat, lon, t (Unix s), seg (stretch index)}].
(function () {
  "use strict";
  var S = (window.Shoreside = window.Shoreside || {});
  var ARROW_EVERY_PX = 100;   // along the track on screen
  var ARROW_CLEAR_PX = 36;    // no arrow this close to another (a vessel holding station)
  var ARROW_SLIDE_PX = 60;    // how far an arrow may move along the track to find room
  var MARK_CLEAR_PX = 14;     // no arrow this close to the start or end
  var TICK_EVERY_PX = 80;     // the tick interval gives at least this much track per tick
  var TICK_CLEAR_PX = 48;     // no time label this close to another (a label is ~40 × 14 px)
  var TICK_CLEAR_Y_PX = 18;
  var TICK_MINUTES = [1, 2, 5, 10, 15, 20, 30, 60, 120, 180, 360, 720, 1440];
  var VIEW_PAD = 0.25;        // marks are placed in the view and this much around it

  // The drawn points in layer pixels, cached while the zoom and the layer origin (which a
  // view reset moves) stay.
  function projected(map, points) {
    var origin = map.getPixelOrigin(), key = map.getZoom() + "/" + origin.x + "/" + origin.y;
    if (points._key !== key || !points._px) {
      points._px = points.map(function (p) { return map.latLngToLayerPoint([p.lat, p.lon]); });
      points._key = key;
    }
    return points._px;
  }

  // Consecutive points of one stretch: the pieces of the drawn line.
  function eachPiece(points, fn) {
    for (var i = 0; i + 1 < points.length; i++) {
      if (points[i].seg === points[i + 1].seg) { fn(i, i + 1); }
    }
  }

  // The point of the drawn track nearest `layerPoint`, if within `maxPx`:
  // {lat, lon, t, px}, the time interpolated along the piece it falls on.
  S.nearestOnTrack = function (map, points, layerPoint, maxPx) {
    if (!points.length) { return null; }
    var px = projected(map, points), best = null;
    function consider(i, j) {
      var a = px[i], b = px[j], dx = b.x - a.x, dy = b.y - a.y, len2 = dx * dx + dy * dy;
      var f = len2 ? ((layerPoint.x - a.x) * dx + (layerPoint.y - a.y) * dy) / len2 : 0;
      f = Math.max(0, Math.min(1, f));
      var x = a.x + f * dx, y = a.y + f * dy, d = Math.hypot(layerPoint.x - x, layerPoint.y - y);
      if (!best || d < best.px) {
        var p = points[i], q = points[j];
        best = {
          px: d, lat: p.lat + f * (q.lat - p.lat), lon: p.lon + f * (q.lon - p.lon),
          t: p.t === null || q.t === null ? (p.t === null ? q.t : p.t) : p.t + f * (q.t - p.t),
        };
      }
    }
    eachPiece(points, consider);
    if (!best) { consider(0, 0); } // a lone point
    return best && best.px <= maxPx ? best : null;
  };

  // The tick interval (minutes) that leaves TICK_EVERY_PX of track between ticks on average.
  function tickMinutes(lengthPx, durationS) {
    if (!(lengthPx > 0) || !(durationS > 0)) { return null; }
    var pxPerS = lengthPx / durationS;
    for (var k = 0; k < TICK_MINUTES.length; k++) {
      if (TICK_MINUTES[k] * 60 * pxPerS >= TICK_EVERY_PX) { return TICK_MINUTES[k]; }
    }
    return TICK_MINUTES[TICK_MINUTES.length - 1];
  }

  // No placed mark within minX across and minY down of (x, y).
  function clear(placed, x, y, minX, minY) {
    return placed.every(function (p) { return Math.abs(p.x - x) >= minX || Math.abs(p.y - y) >= minY; });
  }

  function box(x0, x1, y0, y1) { return { x0: x0, x1: x1, y0: y0, y1: y1 }; }

  function utcLabel(t, withDay) {
    var iso = new Date(t * 1000).toISOString();
    return (withDay ? iso.slice(5, 10) + " " : "") + iso.slice(11, 16);
  }

  // Arrows and time ticks for the points, redrawn when the map zooms or moves.
  S.TrackMarks = L.LayerGroup.extend({
    initialize: function (points) {
      L.LayerGroup.prototype.initialize.call(this);
      this.points = points;
      this.minutes = null;
    },
    onAdd: function (map) {
      L.LayerGroup.prototype.onAdd.call(this, map);
      map.on("zoomend moveend", this.redraw, this);
      this.redraw();
    },
    onRemove: function (map) {
      map.off("zoomend moveend", this.redraw, this);
      L.LayerGroup.prototype.onRemove.call(this, map);
    },
    redraw: function () {
      var map = this._map, points = this.points;
      if (!map) { return; }
      this.clearLayers();
      var px = projected(map, points), size = map.getSize(), origin = map.containerPointToLayerPoint([0, 0]);
      var lo = L.point(origin.x - size.x * VIEW_PAD, origin.y - size.y * VIEW_PAD);
      var hi = L.point(origin.x + size.x * (1 + VIEW_PAD), origin.y + size.y * (1 + VIEW_PAD));
      function inView(x, y) { return x >= lo.x && x <= hi.x && y >= lo.y && y <= hi.y; }
      var length = 0, duration = 0;
      eachPiece(points, function (i, j) {
        length += px[i].distanceTo(px[j]);
        if (points[i].t !== null && points[j].t !== null) { duration += points[j].t - points[i].t; }
      });
      var minutes = (this.minutes = tickMinutes(length, duration));
      var days = points.length && new Date(points[0].t * 1000).toISOString().slice(0, 10) !==
        new Date(points[points.length - 1].t * 1000).toISOString().slice(0, 10);
      var ticks = [], self = this;
      // A tick at every whole multiple of the interval (UTC), where the track was then.
      eachPiece(points, function (i, j) {
        var a = px[i], b = px[j], p = points[i], q = points[j];
        if (!minutes || p.t === null || q.t === null || q.t <= p.t) { return; }
        var step = minutes * 60, stretchEnd = j === points.length - 1 || points[j + 1].seg !== q.seg;
        for (var t = Math.ceil(p.t / step) * step; t < q.t || (t === q.t && stretchEnd); t += step) {
          var f = (t - p.t) / (q.t - p.t), x = a.x + (b.x - a.x) * f, y = a.y + (b.y - a.y) * f;
          if (inView(x, y) && clear(ticks, x, y, TICK_CLEAR_PX, TICK_CLEAR_Y_PX)) {
            ticks.push({ x: x, y: y });
            var midnight = new Date(t * 1000).toISOString().slice(11, 16) === "00:00";
            self.addLayer(tick(map.layerPointToLatLng([x, y]), t, utcLabel(t, days && midnight)));
          }
        }
      });
      // Arrows every ARROW_EVERY_PX of track counted from its start (so a pan does not move
      // them), slid along it until clear of the other arrows, the ticks and their labels
      // (to the right of the dot), and the start and end marks.
      var taken = ticks.map(function (p) { return box(p.x - 10, p.x + 52, p.y - 12, p.y + 13); });
      if (px.length) {
        [px[0], px[px.length - 1]].forEach(function (p) { taken.push(box(p.x - MARK_CLEAR_PX, p.x + MARK_CLEAR_PX, p.y - MARK_CLEAR_PX, p.y + MARK_CLEAR_PX)); });
      }
      function free(x, y) { return taken.every(function (r) { return x < r.x0 || x > r.x1 || y < r.y0 || y > r.y1; }); }
      var pieces = [], total = 0;
      eachPiece(points, function (i, j) {
        var d = px[i].distanceTo(px[j]);
        if (d) { pieces.push({ a: px[i], b: px[j], s: total, d: d }); total += d; }
      });
      var k = 0;
      function along(s) { // the point `s` px along the track, and the way it goes there
        while (k + 1 < pieces.length && pieces[k + 1].s <= s) { k++; }
        var p = pieces[k], f = (s - p.s) / p.d;
        return {
          x: p.a.x + (p.b.x - p.a.x) * f, y: p.a.y + (p.b.y - p.a.y) * f,
          angle: ((Math.atan2(p.b.x - p.a.x, p.a.y - p.b.y) * 180) / Math.PI + 360) % 360,
        };
      }
      for (var s = ARROW_EVERY_PX; s < total; s += ARROW_EVERY_PX) {
        for (var slide = 0; slide <= ARROW_SLIDE_PX && s + slide < total; slide += 6) {
          var at = along(s + slide);
          if (!inView(at.x, at.y)) { break; }
          if (free(at.x, at.y)) {
            taken.push(box(at.x - ARROW_CLEAR_PX, at.x + ARROW_CLEAR_PX, at.y - ARROW_CLEAR_PX, at.y + ARROW_CLEAR_PX));
            this.addLayer(arrow(map.layerPointToLatLng([at.x, at.y]), at.angle));
            break;
          }
        }
      }
    },
  });

  function arrow(latlng, bearing) {
    var html = '<svg width="14" height="14" viewBox="-7 -7 14 14" style="transform: rotate(' +
      bearing.toFixed(1) + 'deg)"><path d="M0,-6 L5,5 L0,2 L-5,5 Z"/></svg>';
    var marker = L.marker(latlng, {
      interactive: false, keyboard: false,
      icon: L.divIcon({ className: "track-arrow", html: html, iconSize: [14, 14], iconAnchor: [7, 7] }),
    });
    marker.on("add", function () { marker.getElement().setAttribute("data-bearing", bearing.toFixed(1)); });
    return marker;
  }

  function tick(latlng, t, text) {
    var marker = L.marker(latlng, {
      interactive: false, keyboard: false,
      icon: L.divIcon({ className: "track-tick", html: "<span>" + text + "</span>", iconSize: [6, 6], iconAnchor: [3, 3] }),
    });
    marker.on("add", function () { marker.getElement().setAttribute("data-time", String(t)); });
    return marker;
  }
})();
