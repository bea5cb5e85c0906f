// Shoreside map basics, shared by every map page (fleet map, track view, mission planner):
// the tile layer from the page's map-config, the offline coastline when there are no tiles
// (MAP_TILES_URL empty, or the tiles fail), a lat/lon graticule and the coordinates under the
// cursor (so a map with no tiles at sea is still a chart), great-circle distance and bearing, and small formatters. Plain Leaflet, no build step.
(function () {
  "use strict";
  var S = (window.Shoreside = window.Shoreside || {});
  // Distance and bearing are edge_client/contract/geo.py's sums, and this is their one
  // JavaScript copy (a page cannot import the contract): tests/browser/test_fleet_map.py
  // compares the two on some five hundred pairs of points. Mean Earth radius, IUGG.
  var EARTH_RADIUS_M = 6371000;
  var GRID_STEPS = [30, 10, 5, 2, 1, 0.5, 0.2, 0.1, 0.05, 0.02, 0.01, 0.005, 0.002, 0.001, 0.0005];
  var GRID_MAX_LINES = 8;
  var LABEL_CLEAR_PX = 18;
  var ZOOM_BUTTONS_PX = 90; // Leaflet's zoom control, top left

  function rad(d) { return (d * Math.PI) / 180; }

  S.geo = {
    // Haversine distance in metres, as edge_client.contract.geo.distance_m.
    distance: function (lat1, lon1, lat2, lon2) {
      var p1 = rad(lat1), p2 = rad(lat2), dp = p2 - p1, dl = rad(lon2 - lon1);
      var a = Math.pow(Math.sin(dp / 2), 2) + Math.cos(p1) * Math.cos(p2) * Math.pow(Math.sin(dl / 2), 2);
      return 2 * EARTH_RADIUS_M * Math.asin(Math.sqrt(Math.min(1, a)));
    },
    // Initial great-circle bearing, degrees true in [0, 360), as edge_client.contract.geo.bearing_deg.
    bearing: function (lat1, lon1, lat2, lon2) {
      var p1 = rad(lat1), p2 = rad(lat2), dl = rad(lon2 - lon1);
      var y = Math.sin(dl) * Math.cos(p2);
      var x = Math.cos(p1) * Math.sin(p2) - Math.sin(p1) * Math.cos(p2) * Math.cos(dl);
      return (((Math.atan2(y, x) * 180) / Math.PI) % 360 + 360) % 360;
    },
  };

  S.json = function (id) {
    var node = document.getElementById(id);
    return node ? JSON.parse(node.textContent) : {};
  };

  S.el = function (tag, attrs, children) {
    var node = document.createElement(tag);
    Object.keys(attrs || {}).forEach(function (k) {
      if (k === "text") { node.textContent = attrs[k]; }
      else if (k === "class") { node.className = attrs[k]; }
      else if (k.slice(0, 2) === "on") { node.addEventListener(k.slice(2), attrs[k]); }
      else { node.setAttribute(k, attrs[k]); }
    });
    (children || []).forEach(function (c) {
      if (c !== null && c !== undefined) { node.appendChild(typeof c === "string" ? document.createTextNode(c) : c); }
    });
    return node;
  };

  S.fmtDistance = function (m) {
    return m < 1000 ? Math.round(m) + " m" : (m / 1000).toFixed(m < 10000 ? 2 : 1) + " km";
  };
  S.fmtDuration = function (s) {
    if (s === null || s === undefined || !isFinite(s)) { return "–"; }
    s = Math.max(0, Math.round(s));
    if (s < 60) { return s + " s"; }
    if (s < 3600) { return Math.floor(s / 60) + " min" + (s < 600 && s % 60 ? " " + (s % 60) + " s" : ""); }
    if (s < 86400) { return Math.floor(s / 3600) + " h " + Math.floor((s % 3600) / 60) + " min"; }
    return Math.floor(s / 86400) + " d " + Math.floor((s % 86400) / 3600) + " h";
  };
  // The one way a page shows a time, a position, a speed and a reading; vessels/display.py
  // writes the same on the server (a browser test compares them).
  var KNOTS_PER_MPS = 3600 / 1852;
  S.fmtTime = function (value) {
    if (value === null || value === undefined) { return "–"; }
    var d = typeof value === "number" ? new Date(value * 1000) : new Date(value);
    return isNaN(d) ? "–" : d.toISOString().slice(0, 19).replace("T", " ") + " UTC";
  };
  S.fmtPosition = function (lat, lon) { return lat.toFixed(5) + "°, " + lon.toFixed(5) + "°"; };
  // Degrees and decimal minutes, as on a chart and a plotter: 32°02.280′S 115°19.950′E.
  S.fmtDDM = function (lat, lon) {
    function part(v, pos, neg) {
      // Minutes rounded first, so 59.9996′ carries into the degrees instead of showing 60.000′.
      var thousandths = Math.round(Math.abs(v) * 60000), d = Math.floor(thousandths / 60000);
      var m = ((thousandths % 60000) / 1000).toFixed(3);
      return d + "°" + (m.length < 6 ? "0" + m : m) + "′" + (v >= 0 ? pos : neg);
    }
    return part(lat, "N", "S") + " " + part(lon, "E", "W");
  };
  // A position in decimal degrees, with the chart form on hover.
  S.positionEl = function (lat, lon) {
    return S.el("span", { class: "position", title: S.fmtDDM(lat, lon), text: S.fmtPosition(lat, lon) });
  };
  S.fmtSpeed = function (mps) {
    if (mps === null || mps === undefined) { return "–"; }
    return mps.toFixed(1) + " m/s (" + (mps * KNOTS_PER_MPS).toFixed(1) + " kn)";
  };
  // Three digits, as a compass course is said: 090°.
  S.fmtHeading = function (deg) {
    if (deg === null || deg === undefined) { return "–"; }
    return ("00" + (Math.round(deg) % 360)).slice(-3) + "°";
  };
  S.fmtNumber = function (v) {
    if (typeof v !== "number") { return String(v); }
    if (Number.isInteger(v)) { return String(v); }
    var text = Math.abs(v) >= 100 ? v.toFixed(1) : v.toFixed(2);
    text = text.replace(/(\.\d*?)0+$/, "$1").replace(/\.$/, "");
    return text === "-0" ? "0" : text;
  };
  S.fmtValue = function (v, unit) {
    if (v === null || v === undefined) { return "–"; }
    var text = S.fmtNumber(v);
    return unit ? text + " " + unit : text;
  };
  // A state channel's value by name (HOLD, armed); null when it has none. `channels` is a
  // page config's channels: the state channels carry {states: {"4": "HOLD"}}.
  S.stateName = function (key, v, channels) {
    var c = channels && channels[key];
    if (!c || !c.states || typeof v !== "number" || !Number.isInteger(v)) { return null; }
    return Object.prototype.hasOwnProperty.call(c.states, String(v)) ? c.states[String(v)] : null;
  };
  // One reading's value as a panel shows it: the state's name, or the number with its unit.
  S.fmtReading = function (key, v, channels) {
    var name = S.stateName(key, v, channels), c = (channels && channels[key]) || {};
    return name !== null ? name : S.fmtValue(v, c.unit || "");
  };
  // A reading's label: the page's channel label, else the key.
  S.channelLabel = function (key, channels) {
    var c = channels && channels[key];
    return (c && c.label) || key;
  };
  // The readings' keys in the order the pages list them: state channels first, then by key.
  S.readingKeys = function (readings, channels) {
    var keys = Object.keys(readings || {});
    function isState(k) { return !!(channels && channels[k] && channels[k].states); }
    // The states in the page config's order (mode, then armed), as vessels/display.py lists them.
    var states = Object.keys(channels || {}).filter(function (k) { return isState(k) && keys.indexOf(k) >= 0; });
    return states.concat(keys.filter(function (k) { return !isState(k); }).sort());
  };

  S.getJSON = function (url, headers) {
    return fetch(url, { credentials: "same-origin", headers: Object.assign({ Accept: "application/json" }, headers || {}) });
  };

  // A lat/lon grid at a round step for the zoom, with its values on the map's left and bottom.
  var Graticule = L.LayerGroup.extend({
    onAdd: function (map) {
      L.LayerGroup.prototype.onAdd.call(this, map);
      map.on("moveend zoomend resize", this._draw, this);
      this._draw();
    },
    onRemove: function (map) {
      map.off("moveend zoomend resize", this._draw, this);
      L.LayerGroup.prototype.onRemove.call(this, map);
    },
    _draw: function () {
      var map = this._map;
      if (!map) { return; }
      this.clearLayers();
      var b = map.getBounds(), south = Math.max(b.getSouth(), -85), north = Math.min(b.getNorth(), 85);
      var west = b.getWest(), east = b.getEast();
      var span = Math.max(north - south, east - west);
      var step = GRID_STEPS[GRID_STEPS.length - 1];
      for (var i = 0; i < GRID_STEPS.length; i++) {
        if (span / GRID_STEPS[i] >= 2) { step = GRID_STEPS[i]; break; }
      }
      if (span / step > GRID_MAX_LINES * 2) { step *= 2; }
      var digits = Math.max(0, Math.ceil(-Math.log10(step)));
      var style = { color: "#5b7389", weight: 1, opacity: 0.45, interactive: false, dashArray: "2 4" };
      var lat0 = Math.ceil(south / step) * step, lon0 = Math.ceil(west / step) * step;
      // Latitudes along the left edge (below the zoom buttons), longitudes along the top: the
      // scale bar, attribution and cursor position sit along the bottom.
      var labelLon = west, labelLat = north;
      var size = map.getSize();
      for (var lat = lat0; lat <= north; lat += step) {
        this.addLayer(L.polyline([[lat, west], [lat, east]], style));
        var y = map.latLngToContainerPoint([lat, west]).y;
        // Not under the zoom buttons, nor the scale bar along the bottom.
        if (y > ZOOM_BUTTONS_PX && y < size.y - 2 * LABEL_CLEAR_PX) {
          this.addLayer(this._label([lat, labelLon], lat.toFixed(digits) + "°", "lat"));
        }
      }
      for (var lon = lon0; lon <= east; lon += step) {
        this.addLayer(L.polyline([[south, lon], [north, lon]], style));
        var x = map.latLngToContainerPoint([north, lon]).x;
        // Not under the zoom buttons, and the whole label inside the map.
        if (x > 3 * LABEL_CLEAR_PX && x < size.x - 4 * LABEL_CLEAR_PX) {
          this.addLayer(this._label([labelLat, lon], lon.toFixed(digits) + "°", "lon"));
        }
      }
    },
    _label: function (latlng, text, axis) {
      return L.marker(latlng, {
        interactive: false, keyboard: false,
        icon: L.divIcon({ className: "graticule-label graticule-" + axis, html: "<span>" + text + "</span>", iconSize: [0, 0] }),
      });
    },
  });

  var CursorPosition = L.Control.extend({
    options: { position: "bottomright" },
    onAdd: function (map) {
      var box = L.DomUtil.create("div", "leaflet-control cursor-position");
      box.hidden = true; // until the pointer is over the map
      map.on("mousemove", function (e) {
        box.hidden = false;
        box.textContent = S.fmtPosition(e.latlng.lat, e.latlng.lng) + "  ·  " + S.fmtDDM(e.latlng.lat, e.latlng.lng);
      });
      return box;
    },
  });

  // The offline coastline (issue 18 §1): Natural Earth land, drawn under everything when there
  // are no tiles (MAP_TILES_URL empty, or the tile server does not answer). Static files made by
  // `manage.py build_coastline` (see vessels/static/vessels/vendor/naturalearth/README.md): an
  // index, then per level the world or 5°×5° cells, only those in view fetched.
  var COAST_PANE = "coastline";
  var LAND_STYLE = { stroke: false, fill: true, fillColor: "#f3efe2", fillOpacity: 1, interactive: false };
  var COAST_STYLE = { color: "#6d7d8b", weight: 1.2, opacity: 0.9, fill: false, interactive: false };
  var TILE_ERRORS_IN_A_ROW = 4; // then the tiles count as unavailable
  S.TILE_RETRY_MS = 5 * 60 * 1000; // tiles tried again after this long (a test may shorten it)

  // One fetch per URL for every map of the page; a failed one is forgotten, tried on the next move.
  var fetched = {};
  function fetchJSON(url) {
    if (!fetched[url]) {
      fetched[url] = fetch(url, { credentials: "same-origin" }).then(function (r) {
        if (!r.ok) { throw new Error(url + ": HTTP " + r.status); }
        return r.json();
      });
      fetched[url].catch(function () { delete fetched[url]; });
    }
    return fetched[url];
  }

  // A TopoJSON topology's `land` and `coastline` as Leaflet latlngs ([lat, lon]).
  S.topoDecode = function (topo) {
    var t = topo.transform;
    var arcs = topo.arcs.map(function (arc) {
      var x = 0, y = 0;
      return arc.map(function (p) {
        if (!t) { return [p[1], p[0]]; }
        x += p[0]; y += p[1];
        return [y * t.scale[1] + t.translate[1], x * t.scale[0] + t.translate[0]];
      });
    });
    function line(indexes) {
      var out = [];
      indexes.forEach(function (i) {
        var arc = i >= 0 ? arcs[i] : arcs[~i].slice().reverse();
        for (var k = out.length ? 1 : 0; k < arc.length; k++) { out.push(arc[k]); }
      });
      return out;
    }
    function geometry(g) {
      if (!g) { return []; }
      if (g.type === "Polygon") { return [g.arcs.map(line)]; }
      if (g.type === "MultiPolygon") { return g.arcs.map(function (p) { return p.map(line); }); }
      if (g.type === "LineString") { return [line(g.arcs)]; }
      if (g.type === "MultiLineString") { return g.arcs.map(line); }
      return [];
    }
    return { land: geometry(topo.objects.land), coast: geometry(topo.objects.coastline) };
  };

  function cellName(lat, lon) {
    return (lat < 0 ? "s" : "n") + Math.abs(lat) + (lon < 0 ? "w" : "e") + Math.abs(lon);
  }

  // The index's cells of `level` that the bounds touch.
  function cellsInView(level, bounds) {
    if (!level.cell) { return level.cells.slice(); }
    var have = level.have || (level.have = new Set(level.cells)), c = level.cell, found = [];
    var south = Math.max(-90, Math.floor(bounds.getSouth() / c) * c), north = Math.min(90, bounds.getNorth());
    var west = Math.max(-180, Math.floor(bounds.getWest() / c) * c), east = Math.min(180, bounds.getEast());
    for (var lat = south; lat < north; lat += c) {
      for (var lon = west; lon < east; lon += c) {
        if (have.has(cellName(lat, lon))) { found.push(cellName(lat, lon)); }
      }
    }
    return found;
  }

  var Coastline = L.Layer.extend({
    options: { attribution: "Natural Earth" },
    initialize: function (indexUrl) {
      this._indexUrl = indexUrl;
      this._drawn = {}; // "10m/s35e115": "loading" or its layer
      this.loaded = []; // what was drawn, in order (the tests read it)
    },
    onAdd: function (map) {
      if (!map.getPane(COAST_PANE)) {
        // Above the tile pane (200), below the overlay pane (400) with tracks, routes and markers.
        var pane = map.createPane(COAST_PANE);
        pane.style.zIndex = 250;
        pane.style.pointerEvents = "none";
      }
      this._renderer = this._renderer || L.svg({ pane: COAST_PANE, padding: 0.3 });
      this._group = L.layerGroup().addTo(map);
      map.on("moveend", this._update, this);
      this._update();
    },
    onRemove: function (map) {
      map.off("moveend", this._update, this);
      map.removeLayer(this._group);
      this._drawn = {};
    },
    _update: function () {
      var self = this, map = this._map;
      if (!map) { return; }
      fetchJSON(this._indexUrl).then(function (index) {
        if (self._map !== map) { return; }
        var zoom = map.getZoom(), level = index.levels[0];
        index.levels.forEach(function (l) { if (l.minzoom <= zoom) { level = l; } });
        // The index's URL may carry a hash (manifest storage); the cells sit beside it.
        var base = self._indexUrl.replace(/[^/]*$/, "") + index.base + level.name + "/";
        self._level = level.name;
        self.zoom = zoom; // the zoom the cells below were chosen for
        self._wanted = cellsInView(level, map.getBounds().pad(0.1)).map(function (cell) {
          var key = level.name + "/" + cell;
          if (!self._drawn[key]) { self._load(map, key, base + cell + ".json"); }
          return key;
        });
        self._prune();
      }).catch(function (e) { window.console.warn("coastline index:", e); });
    },
    _load: function (map, key, url) {
      var self = this;
      this._drawn[key] = "loading";
      fetchJSON(url).then(function (topo) {
        if (self._map !== map || self._drawn[key] !== "loading") { return; }
        var g = S.topoDecode(topo), renderer = self._renderer;
        self._drawn[key] = L.layerGroup([
          L.polygon(g.land, L.extend({ renderer: renderer }, LAND_STYLE)),
          L.polyline(g.coast, L.extend({ renderer: renderer }, COAST_STYLE)),
        ]).addTo(self._group);
        self.loaded.push(key);
        self._prune();
      }, function (e) {
        if (self._drawn[key] === "loading") { delete self._drawn[key]; }
        window.console.warn("coastline cell:", e);
      });
    },
    // True when every cell the view wants is drawn (the tests wait for it).
    settled: function () {
      var drawn = this._drawn;
      return !!this._map && this.zoom === this._map.getZoom() &&
        this._wanted.every(function (k) { return drawn[k] && drawn[k] !== "loading"; });
    },
    // Once the level in view is all drawn, the other levels go (no bare sea in between).
    _prune: function () {
      var drawn = this._drawn, level = this._level;
      var ready = (this._wanted || []).every(function (k) { return drawn[k] && drawn[k] !== "loading"; });
      if (!ready) { return; }
      Object.keys(drawn).forEach(function (k) {
        if (k.split("/")[0] !== level) {
          if (drawn[k] !== "loading") { this._group.removeLayer(drawn[k]); }
          delete drawn[k];
        }
      }, this);
    },
  });

  // The map's base: the tiles while they load, else the coastline with a word on the map.
  function BaseLayer(map, config) {
    this.map = map;
    this.config = config;
    this.coastline = config.coastline ? new Coastline(config.coastline) : null;
    this.tiles = null;
    this.banner = L.DomUtil.create("div", "map-banner", map.getContainer());
    this.banner.setAttribute("role", "status");
    this.banner.hidden = true;
    if (config.tiles_url) { this.tryTiles(); } else { this.offline(""); }
  }
  BaseLayer.prototype.offline = function (why) {
    var map = this.map;
    L.DomUtil.addClass(map.getContainer(), "no-tiles");
    map.getContainer().setAttribute("data-base", "coastline");
    if (this.coastline && !map.hasLayer(this.coastline)) { this.coastline.addTo(map); }
    this.banner.textContent = why;
    this.banner.hidden = !why;
  };
  BaseLayer.prototype.online = function () {
    var map = this.map;
    L.DomUtil.removeClass(map.getContainer(), "no-tiles");
    map.getContainer().setAttribute("data-base", "tiles");
    if (this.coastline && map.hasLayer(this.coastline)) { map.removeLayer(this.coastline); }
    this.banner.hidden = true;
  };
  BaseLayer.prototype.tryTiles = function () {
    var self = this, errors = 0, map = this.map;
    var tiles = (this.tiles = L.tileLayer(this.config.tiles_url, { attribution: this.config.attribution, maxZoom: 19 }));
    tiles.on("tileload", function () {
      errors = 0;
      if (map.getContainer().getAttribute("data-base") !== "tiles") { self.online(); }
    });
    tiles.on("tileerror", function () {
      errors += 1;
      if (errors < TILE_ERRORS_IN_A_ROW || !map.hasLayer(tiles)) { return; }
      // No more requests to a server that does not answer: the layer goes, back in a while.
      map.removeLayer(tiles);
      self.tiles = null;
      self.offline(self.coastline ? "map tiles unavailable: showing the offline coastline" : "map tiles unavailable");
      self.retryAt = Date.now() + S.TILE_RETRY_MS;
      window.setTimeout(function () { self.tryTiles(); }, S.TILE_RETRY_MS);
    });
    tiles.addTo(map);
  };

  // Every map's base layers, by the map element's id (the tests read them).
  S.maps = {};

  // Base layer (tiles or coastline), graticule and cursor position on a map made by django-leaflet's tag.
  S.baseMap = function (map) {
    var config = S.json("map-config");
    S.maps[map.getContainer().id] = new BaseLayer(map, config);
    new Graticule().addTo(map);
    new CursorPosition().addTo(map);
    return config;
  };
})();
