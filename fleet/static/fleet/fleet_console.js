// The fleet map as a console (issue 18 §2): each vessel's trail of recent positions fading
// with age, the mission it runs with the waypoint it is heading to, and vessel labels that
// give way to each other when zoomed out. Used by fleet_map.js (window.Shoreside.fleetConsole).
//
// Trails, missions and endurance come from /api/v1/fleet/overlays/, read every trailRefreshS seconds
// (with If-None-Match); in between, every fleet poll's last fixes extend the trails, so the
// fleet poll stays as cheap as it was.
(function () {
  "use strict";
  var S = window.Shoreside;
  var el = S.el;
  // A trail is drawn in this many age bands, the newest opaque, each older one fainter.
  var TRAIL_BANDS = 6;
  var TRAIL_NEWEST = 0.9;
  var TRAIL_OLDEST = 0.15;
  // Trail colours: none of them a state colour (green, red, grey) nor the mission's.
  var PALETTE = ["#1565c0", "#00897b", "#d81b60", "#3949ab", "#0097a7", "#6d4c41"];
  var LEG = {
    done: { color: "#9e9e9e", weight: 3, opacity: 0.35, dashArray: "2 6" },
    active: { color: "#ff6f00", weight: 5, opacity: 1 },
    todo: { color: "#7b1fa2", weight: 3, opacity: 0.85 },
    pending: { color: "#7b1fa2", weight: 3, opacity: 0.6, dashArray: "8 6" },
    loop: { color: "#7b1fa2", weight: 2, opacity: 0.6, dashArray: "4 8" },
  };
  var GROUP_MAX_ZOOM = 17;

  function colourOf(slug) {
    var h = 0;
    for (var i = 0; i < slug.length; i++) { h = (h * 31 + slug.charCodeAt(i)) >>> 0; }
    return PALETTE[h % PALETTE.length];
  }

  function trailOpacity(band) {
    return TRAIL_NEWEST - (TRAIL_NEWEST - TRAIL_OLDEST) * band / (TRAIL_BANDS - 1);
  }

  // Lines of [t, lat, lon] cut into runs of one age band each (band 0: the newest sixth of
  // the window). A run shares its first point with the run before, so the line is unbroken.
  function bandRuns(lines, nowS, spanS) {
    var runs = [];
    lines.forEach(function (line) {
      var run = null;
      for (var i = 1; i < line.length; i++) {
        var a = line[i - 1], b = line[i];
        // A leg fades with its older end: the band of the time it was sailed from.
        var band = Math.min(TRAIL_BANDS - 1, Math.max(0, Math.floor((nowS - a[0]) / spanS * TRAIL_BANDS)));
        if (!run || run.band !== band) {
          run = { band: band, points: [[a[1], a[2]]] };
          runs.push(run);
        }
        run.points.push([b[1], b[2]]);
      }
    });
    return runs;
  }

  function Overlays(fleet) {
    this.fleet = fleet;
    this.map = fleet.map;
    this.cfg = fleet.cfg;
    this.minutes = this.cfg.trailMinutes;
    this.trails = {}; // slug -> {gap_s, lines: [[[t, lat, lon], ...], ...]}
    this.missions = {}; // slug -> the running mission (fleet.console.mission_entry)
    this.endurance = {}; // slug -> {hours, text}: the battery's, day over day
    this.trailGroups = {};
    this.missionGroups = {};
    this.etag = null;
    this.refreshes = 0; // answered reads, for the browser tests
    this.version = 0;
    if (!this.cfg.overlaysUrl) { return; }
    this.addControl();
    var self = this;
    document.addEventListener("visibilitychange", function () {
      if (!document.hidden && self.stale) { self.refresh(); }
    });
    this.refresh();
  }

  Overlays.prototype.addControl = function () {
    var self = this;
    var Control = L.Control.extend({
      onAdd: function () {
        var select = el("select", { class: "trail-minutes", title: "How long a trail each vessel draws" });
        self.cfg.trailChoices.forEach(function (m) {
          var text = m === 0 ? "off" : m < 60 ? m + " min" : m / 60 + " h";
          var option = el("option", { value: String(m), text: text });
          if (m === self.minutes) { option.selected = true; }
          select.appendChild(option);
        });
        select.addEventListener("change", function () { self.setMinutes(Number(select.value)); });
        var box = el("div", { class: "leaflet-bar trail-control" }, [el("label", {}, ["Trail ", select])]);
        L.DomEvent.disableClickPropagation(box);
        L.DomEvent.disableScrollPropagation(box);
        return box;
      },
    });
    new Control({ position: "topright" }).addTo(this.map);
  };

  Overlays.prototype.setMinutes = function (minutes) {
    this.minutes = minutes;
    this.etag = null;
    this.refresh();
  };

  Overlays.prototype.refresh = function () {
    var self = this;
    clearTimeout(this.timer);
    if (document.hidden) { this.stale = true; return; }
    this.stale = false;
    var minutes = this.minutes;
    var headers = this.etag ? { "If-None-Match": this.etag } : {};
    S.getJSON(this.cfg.overlaysUrl + "?minutes=" + minutes, headers)
      .then(function (r) {
        if (r.status === 304) { return null; }
        if (!r.ok) { throw new Error("HTTP " + r.status); }
        self.etag = r.headers.get("ETag");
        return r.json();
      })
      .then(function (data) {
        self.refreshes += 1;
        if (data && minutes === self.minutes) { self.load(data); }
      })
      .catch(function () { self.etag = null; }) // the fleet poll reports a dead link
      .then(function () {
        // Only the newest read schedules the next one (a changed length starts its own).
        if (minutes !== self.minutes) { return; }
        clearTimeout(self.timer);
        self.timer = setTimeout(function () { self.refresh(); }, self.cfg.trailRefreshS * 1000);
      });
  };

  Overlays.prototype.load = function (data) {
    var self = this;
    this.trails = {};
    this.missions = {};
    this.endurance = {};
    data.vessels.forEach(function (o) {
      if (o.trail) { self.trails[o.slug] = o.trail; }
      if (o.mission) { self.missions[o.slug] = o.mission; }
      if (o.endurance) { self.endurance[o.slug] = o.endurance; }
    });
    this.version += 1;
    S.fleetConsole.drawFences(this, data.fences);
    this.drawAll();
    this.fleet.overlaysChanged();
  };

  // After each fleet poll: a newer last fix extends its vessel's trail (a new line after a
  // silence longer than the trail's gap), and the oldest points fall out of the window.
  Overlays.prototype.fleetUpdated = function () {
    var self = this, fleet = this.fleet;
    Object.keys(this.trails).forEach(function (slug) {
      var v = fleet.vessels[slug], fix = v && v.last_fix, trail = self.trails[slug];
      if (fix) {
        var t = Date.parse(fix.time) / 1000, line = trail.lines[trail.lines.length - 1];
        var last = line && line[line.length - 1];
        if (!last || t > last[0]) {
          var point = [t, fix.lat, fix.lon];
          if (!last || t - last[0] > trail.gap_s) { trail.lines.push([point]); } else { line.push(point); }
        }
      }
      self.prune(trail);
    });
    this.drawAll();
  };

  Overlays.prototype.prune = function (trail) {
    var oldest = this.fleet.now() / 1000 - this.minutes * 60;
    trail.lines = trail.lines
      .map(function (line) { return line.filter(function (p) { return p[0] >= oldest; }); })
      .filter(function (line) { return line.length; });
  };

  Overlays.prototype.drawAll = function () {
    var self = this;
    var slugs = {};
    Object.keys(this.trails).concat(Object.keys(this.trailGroups)).forEach(function (s) { slugs[s] = true; });
    Object.keys(slugs).forEach(function (slug) { self.drawTrail(slug); });
    slugs = {};
    Object.keys(this.missions).concat(Object.keys(this.missionGroups)).forEach(function (s) { slugs[s] = true; });
    Object.keys(slugs).forEach(function (slug) { self.drawMission(slug); });
  };

  Overlays.prototype.group = function (groups, slug) {
    if (!groups[slug]) { groups[slug] = L.layerGroup().addTo(this.map); }
    groups[slug].clearLayers();
    return groups[slug];
  };

  Overlays.prototype.drawTrail = function (slug) {
    var group = this.group(this.trailGroups, slug), trail = this.trails[slug];
    if (!trail || !this.minutes || !this.fleet.vessels[slug]) { return; }
    var colour = colourOf(slug);
    // Oldest first, so the newest bands lie on top where a trail crosses itself.
    bandRuns(trail.lines, this.fleet.now() / 1000, this.minutes * 60)
      .sort(function (a, b) { return b.band - a.band; })
      .forEach(function (run) {
        var line = L.polyline(run.points, {
          color: colour, weight: 3, opacity: trailOpacity(run.band), interactive: false,
          className: "fleet-trail trail-band-" + run.band,
        }).addTo(group);
        var path = line.getElement();
        if (path) { path.setAttribute("data-slug", slug); path.setAttribute("data-band", String(run.band)); }
      });
  };

  // The waypoint the vessel reports heading to, in the operator's numbers, when its fixes
  // count the same waypoints as the mission it runs: {number, count} or null.
  Overlays.prototype.progress = function (slug) {
    var m = this.missions[slug], v = this.fleet.vessels[slug];
    var readings = v && v.last_fix && v.last_fix.readings;
    if (!m || m.status !== "acknowledged" || !readings) { return null; }
    var number = readings.waypoint, count = readings.waypoints;
    if (count !== m.items.length || !(number >= 1 && number <= count) || Math.floor(number) !== number) { return null; }
    return { number: number, count: count };
  };

  Overlays.prototype.drawMission = function (slug) {
    var group = this.group(this.missionGroups, slug), m = this.missions[slug], v = this.fleet.vessels[slug];
    if (!m || !m.items.length || !v) { return; }
    var points = m.items.map(function (i) { return [i.lat, i.lon]; });
    var progress = this.progress(slug), current = progress ? progress.number : null;
    var pending = m.status !== "acknowledged";
    var selected = this.fleet.selected === slug;
    function leg(from, to, state) {
      var style = LEG[state];
      var line = L.polyline([from, to], {
        color: style.color, weight: style.weight + (selected ? 1 : 0), opacity: style.opacity,
        dashArray: style.dashArray || null, interactive: false, className: "mission-leg " + state,
      }).addTo(group);
      var path = line.getElement();
      if (path) { path.setAttribute("data-slug", slug); }
      return line;
    }
    var fix = v.last_fix, here = fix ? [fix.lat, fix.lon] : null;
    for (var i = 1; i < points.length; i++) {
      // Leg i ends at waypoint i + 1: sailed once the vessel heads beyond it. The leg it is
      // on is cut where it is: behind it sailed (dimmed), ahead of it the active part.
      var to = i + 1;
      if (pending) { leg(points[i - 1], points[i], "pending"); }
      else if (current === null || to > current) { leg(points[i - 1], points[i], "todo"); }
      else if (to < current) { leg(points[i - 1], points[i], "done"); }
      else if (here) { leg(points[i - 1], here, "done"); }
      else { leg(points[i - 1], points[i], "active"); }
    }
    if (m.end === "loop" && points.length > 2) { leg(points[points.length - 1], points[0], "loop"); }
    if (current !== null && here) {
      var ahead = leg(here, points[current - 1], "active").getElement();
      if (ahead) { ahead.classList.add("to-current"); }
    }
    var self = this;
    points.forEach(function (p, index) {
      var number = index + 1;
      var state = pending ? "pending" : current === null ? "todo" : number < current ? "done" : number === current ? "current" : "todo";
      var html = "<span class=\"wp-number\">" + number + "</span>";
      if (state === "current" && selected) {
        html += el("span", { class: "wp-label", text: v.name + ": waypoint " + number + " of " + progress.count }).outerHTML;
      }
      L.marker(p, {
        icon: L.divIcon({ className: "mission-wp " + state, iconSize: [20, 20], iconAnchor: [10, 10], html: html }),
        interactive: false, keyboard: false, zIndexOffset: state === "current" ? -500 : -1000,
        title: self.describe(slug, number),
      }).addTo(group).getElement().setAttribute("data-slug", slug);
    });
  };

  Overlays.prototype.describe = function (slug, number) {
    var m = this.missions[slug];
    return "waypoint " + number + " of " + m.items.length;
  };

  // "waypoint 2 of 4" for the list and the panel; null when there is no running mission.
  Overlays.prototype.progressText = function (slug) {
    var p = this.progress(slug);
    return p ? "waypoint " + p.number + " of " + p.count : null;
  };

  // The panel's mission block for the selected vessel.
  Overlays.prototype.missionBox = function (slug) {
    var m = slug && this.missions[slug], v = slug && this.fleet.vessels[slug];
    if (!m || !v) { return null; }
    var box = el("div", { class: "panel-mission" }, [el("h3", { text: "Mission" })]);
    var p = this.progress(slug), fix = v.last_fix;
    var ends = { stop: "stops at the last waypoint", loop: "starts again after the last waypoint", return_home: "returns home after the last waypoint" };
    var lines = [];
    if (m.status !== "acknowledged") {
      lines.push(m.items.length + " waypoints, " + m.status + ": not running yet");
    } else if (p) {
      var text = "Heading to waypoint " + p.number + " of " + p.count;
      if (fix) {
        var wp = m.items[p.number - 1];
        text += ", " + S.fmtDistance(S.geo.distance(fix.lat, fix.lon, wp.lat, wp.lon)) + " to go";
      }
      lines.push(el("b", { class: "mission-progress", text: text }));
    } else {
      lines.push("Running, " + m.items.length + " waypoints (its fixes do not say which it is heading to)");
    }
    box.appendChild(el("p", {}, lines));
    box.appendChild(el("p", { class: "muted small", text: "Then " + (ends[m.end] || m.end) + "." }));
    return box;
  };

  // --- labels that give way ------------------------------------------------------------------

  function overlaps(a, b) {
    return a.left < b.right && b.left < a.right && a.top < b.bottom && b.top < a.bottom;
  }

  var RANK = { reporting: 0, overdue: 1, "never seen": 2 };
  // A label must not cover another vessel's arrow: this many pixels around its position.
  var CORE_PX = 7;
  // A hidden label is counted by the nearest label shown within this many pixels.
  var GROUP_PX = 80;

  // Hide the labels that would overlap a label kept before them (the selected vessel's first,
  // then reporting before overdue, then by name) or another vessel's arrow; the nearest label
  // kept counts the ones hidden ("+3", a click zooms in to them). Hidden labels keep their
  // place (visibility), so every pass measures them alike.
  function declutter(fleet) {
    var entries = [];
    Object.keys(fleet.markers).forEach(function (slug) {
      var node = fleet.markers[slug].getElement();
      var label = node && node.querySelector(".vessel-label");
      if (!label) { return; }
      var box = node.getBoundingClientRect(), x = (box.left + box.right) / 2, y = (box.top + box.bottom) / 2;
      entries.push({
        slug: slug, node: node, label: label, more: label.querySelector(".label-more"), x: x, y: y,
        core: { left: x - CORE_PX, right: x + CORE_PX, top: y - CORE_PX, bottom: y + CORE_PX },
      });
    });
    entries.sort(function (a, b) {
      if ((a.slug === fleet.selected) !== (b.slug === fleet.selected)) { return a.slug === fleet.selected ? -1 : 1; }
      var ra = RANK[fleet.state(fleet.vessels[a.slug]).status], rb = RANK[fleet.state(fleet.vessels[b.slug]).status];
      if (ra !== rb) { return ra - rb; }
      return fleet.vessels[a.slug].name.localeCompare(fleet.vessels[b.slug].name);
    });
    function blocked(e, kept) {
      for (var k = 0; k < kept.length; k++) { if (overlaps(kept[k].rect, e.rect)) { return true; } }
      for (var i = 0; i < entries.length; i++) {
        if (entries[i] !== e && overlaps(entries[i].core, e.rect)) { return true; }
      }
      return false;
    }
    var hidden = {};
    // A kept label grows by its "+N": measure again until nothing changes (a few passes).
    for (var pass = 0; pass < 4; pass++) {
      var kept = [], changed = false;
      entries.forEach(function (e) {
        if (hidden[e.slug]) { return; }
        e.rect = e.label.getBoundingClientRect();
        if (blocked(e, kept)) { hidden[e.slug] = true; changed = true; } else { kept.push(e); }
      });
      kept.forEach(function (k) { k.group = []; });
      entries.forEach(function (e) {
        if (!hidden[e.slug]) { return; }
        var host = null, best = GROUP_PX;
        kept.forEach(function (k) {
          var d = Math.hypot(k.x - e.x, k.y - e.y);
          if (d <= best) { best = d; host = k; }
        });
        if (host) { host.group.push(e.slug); }
      });
      entries.forEach(function (e) {
        var hide = !!hidden[e.slug], group = hide ? [] : e.group;
        e.label.classList.toggle("decluttered", hide);
        e.label.setAttribute("aria-hidden", hide ? "true" : "false");
        var text = group.length ? "+" + group.length : "";
        if (e.more.textContent !== text) { e.more.textContent = text; }
        e.more.hidden = !text;
        e.more.title = text ? "Also here: " + group.map(function (s) { return fleet.vessels[s].name; }).join(", ") + " (click to zoom in)" : "";
        e.node.setAttribute("data-group", group.join(" "));
      });
      if (!changed) { break; }
    }
  }

  // Zoom in until the vessels a label stands for come apart.
  function zoomToGroup(fleet, slug) {
    var node = fleet.markers[slug] && fleet.markers[slug].getElement();
    var slugs = [slug].concat((node && node.getAttribute("data-group") || "").split(" ").filter(Boolean));
    var bounds = L.latLngBounds(slugs.filter(function (s) { return fleet.markers[s]; }).map(function (s) {
      return fleet.markers[s].getLatLng();
    }));
    var zoom = Math.min(GROUP_MAX_ZOOM, Math.max(fleet.map.getBoundsZoom(bounds.pad(0.6)), fleet.map.getZoom() + 2));
    fleet.map.setView(bounds.getCenter(), zoom);
  }

  S.fleetConsole = S.fleetConsole || {};
  S.fleetConsole.Overlays = Overlays;
  S.fleetConsole.declutter = declutter;
  S.fleetConsole.zoomToGroup = zoomToGroup;
  S.fleetConsole.colourOf = colourOf;
})();
