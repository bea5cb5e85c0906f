// The fleet map (issue 9 §1, §4; issue 18 §2): every vessel at its last position, an arrow
// for its heading, coloured by state, labelled with its name and the age of its last fix; it
// polls /api/v1/fleet/ with If-None-Match and never moves the operator's view after the first
// fit. Beside it, the list of vessels (state, age, battery, mission progress); clicking one
// there or on the map opens the side panel: readings with units, its mission, its commands
// moving through their states, links, and the command actions (through the operator command
// API: fleet_commands.js). Trails, missions and labels that give way: fleet_console.js.
(function () {
  "use strict";
  var S = window.Shoreside;
  var el = S.el;
  var COLOURS = { reporting: "#2e7d32", overdue: "#c62828", "never seen": "#757575" };
  var FIT_MAX_ZOOM = 14;
  // The map fills the window below the page header, but never shrinks below this.
  var MIN_HEIGHT_PX = 420;

  function FleetMap(map, cfg) {
    this.map = map;
    this.cfg = cfg;
    this.vessels = {};
    this.order = [];
    this.markers = {};
    this.etag = null;
    this.fitted = false;
    this.clockOffsetMs = 0;
    this.selected = null;
    this.pick = null;
    this.pending = null;
    this.message = null;
    this.commands = null;
    this.polls = 0; // answered polls, and how many of them were 304s (the browser tests read them)
    this.notModified = 0;
    this.overlay = L.layerGroup().addTo(map); // the point being picked
    this.targets = L.layerGroup().addTo(map); // where the open move_to commands go
    this.panel = document.getElementById("fleet-panel");
    this.panel.innerHTML = "";
    // The list of vessels stays at the top; the selected vessel's panel scrolls below it.
    this.listBox = this.panel.appendChild(el("div", { class: "vessel-list-box" }));
    this.body = this.panel.appendChild(el("div", { class: "panel-body" }));
    this.head = this.body.appendChild(el("div", { class: "panel-head" }));
    this.alertsBox = this.body.appendChild(el("div", { class: "panel-alerts" }));
    this.missionBox = this.body.appendChild(el("div", { class: "panel-mission-box" }));
    this.actionsBox = this.body.appendChild(el("div", { class: "panel-actions" }));
    this.commandsBox = this.body.appendChild(el("div", { class: "panel-commands" }));
    // The readings last: commands and their states stay in view without scrolling.
    this.readingsBox = this.body.appendChild(el("div", { class: "panel-readings" }));
    var self = this;
    map.on("click", function (e) { self.mapClicked(e.latlng); });
    map.on("zoomend moveend", function () { S.fleetConsole.declutter(self); });
    window.addEventListener("resize", function () { self.fitWindow(); });
    this.fitWindow();
    this.overlays = new S.fleetConsole.Overlays(this);
    this.alerts = new S.fleetConsole.Alerts(this);
    this.list = new S.fleetConsole.VesselList(this, this.listBox);
    document.addEventListener("keydown", function (e) {
      if (e.key === "Escape") { self.cancelPick(); }
    });
    document.addEventListener("visibilitychange", function () { if (!document.hidden) { self.poll(); } });
    this.poll();
    setInterval(function () { self.tick(); }, 1000);
  }

  FleetMap.prototype.now = function () { return Date.now() + this.clockOffsetMs; };

  // The map and its side column fill the window from where they start down to its bottom.
  FleetMap.prototype.fitWindow = function () {
    var layout = this.map.getContainer().closest(".fleet-map-layout");
    if (!layout) { return; }
    var top = layout.getBoundingClientRect().top + window.scrollY;
    var height = Math.max(MIN_HEIGHT_PX, window.innerHeight - top - 8);
    if (layout.style.height !== height + "px") {
      layout.style.height = height + "px";
      this.map.invalidateSize();
    }
  };

  // Age of the last fix, and the state by the vessel's own period (the server's rule, kept
  // current between polls: a 304 answers nothing about time passing).
  FleetMap.prototype.state = function (v) {
    var seen = v.last_seen_at ? Date.parse(v.last_seen_at) : null;
    var status = v.status;
    if (seen !== null) {
      var late = this.now() - seen > this.cfg.overduePeriods * v.telemetry_period_s * 1000;
      status = late ? "overdue" : "reporting";
    }
    var fixAge = v.last_fix ? (this.now() - Date.parse(v.last_fix.time)) / 1000 : null;
    return { status: status, fixAge: fixAge };
  };

  FleetMap.prototype.poll = function () {
    var self = this;
    clearTimeout(this.pollTimer);
    // A hidden tab costs the link nothing (becoming visible polls again); one poll at a time.
    if (document.hidden || this.inFlight) { return; }
    this.inFlight = true;
    var headers = this.etag ? { "If-None-Match": this.etag } : {};
    S.getJSON(this.cfg.fleetUrl, headers)
      .then(function (r) {
        self.polls += 1;
        if (r.status === 304) { self.notModified += 1; return null; }
        if (!r.ok) { throw new Error("the fleet data answered HTTP " + r.status); }
        self.etag = r.headers.get("ETag");
        return r.json();
      })
      .then(function (data) {
        self.setStale(null);
        if (data) { self.update(data); }
      })
      .catch(function (err) { self.setStale(String(err.message || err)); })
      .then(function () {
        self.inFlight = false;
        self.pollTimer = setTimeout(function () { self.poll(); }, self.cfg.pollS * 1000);
      });
  };

  FleetMap.prototype.setStale = function (text) {
    var box = document.getElementById("fleet-map-status");
    if (box) { box.textContent = text ? "Not updating: " + text : ""; box.hidden = !text; }
  };

  FleetMap.prototype.update = function (data) {
    var self = this;
    if (data.server_time) { this.clockOffsetMs = Date.parse(data.server_time) - Date.now(); }
    this.version = (this.version || 0) + 1;
    var seen = {};
    this.order = [];
    data.vessels.forEach(function (v) {
      seen[v.slug] = true;
      self.order.push(v.slug);
      self.vessels[v.slug] = v;
      self.placeMarker(v);
    });
    Object.keys(this.markers).forEach(function (slug) {
      if (!seen[slug]) { self.map.removeLayer(self.markers[slug]); delete self.markers[slug]; }
    });
    Object.keys(this.vessels).forEach(function (slug) { if (!seen[slug]) { delete self.vessels[slug]; } });
    this.overlays.fleetUpdated();
    if (!this.fitted) {
      var points = Object.keys(this.markers).map(function (s) { return self.markers[s].getLatLng(); });
      if (points.length) {
        // Not animated: Leaflet drops a setView that comes while a zoom animates, so a click
        // on "+3" just after the page loads would do nothing.
        this.map.fitBounds(L.latLngBounds(points).pad(0.2), { maxZoom: FIT_MAX_ZOOM, animate: false });
        this.fitted = true;
      }
    }
    this.tick();
    if (this.selected && !this.vessels[this.selected]) { this.select(null); }
  };

  FleetMap.prototype.placeMarker = function (v) {
    var self = this;
    var fix = v.last_fix;
    var marker = this.markers[v.slug];
    if (!fix) {
      if (marker) { this.map.removeLayer(marker); delete this.markers[v.slug]; }
      return;
    }
    if (!marker) {
      marker = L.marker([fix.lat, fix.lon], {
        icon: L.divIcon({ className: "vessel-icon", iconSize: [26, 26], iconAnchor: [13, 13], html: "" }),
        title: v.name,
        riseOnHover: true,
      });
      marker.on("click", function (e) {
        // The "+3" on a label stands for the vessels it hides: a click there zooms in to them.
        var target = e.originalEvent && e.originalEvent.target;
        if (target && target.closest && target.closest(".label-more")) {
          S.fleetConsole.zoomToGroup(self, v.slug);
          return;
        }
        self.select(v.slug);
      });
      marker.addTo(this.map);
      this.markers[v.slug] = marker;
    } else {
      marker.setLatLng([fix.lat, fix.lon]);
    }
  };

  // The marker's look (shape, colour, heading, name); its age text is set apart, every second.
  FleetMap.prototype.markerHtml = function (v, st) {
    var colour = COLOURS[st.status] || COLOURS["never seen"];
    var heading = v.last_fix && v.last_fix.heading_deg;
    var shape = heading === null || heading === undefined
      ? '<circle r="7" />'
      : '<path d="M0,-12 L7.5,9 L0,4.5 L-7.5,9 Z" transform="rotate(' + Number(heading) + ')" />';
    var label = el("div", { class: "vessel-label" }, [
      el("b", { text: v.name }), " ", el("span", { class: "vessel-age" }), el("span", { class: "label-more", hidden: "" }),
    ]);
    return (
      '<svg class="vessel-arrow" viewBox="-13 -13 26 26" width="26" height="26" style="fill:' + colour +
      '">' + shape + "</svg>" + this.alerts.badgeHtml(v.slug) + label.outerHTML
    );
  };

  // Every second: ages move on and a silent vessel turns overdue. Nothing is rebuilt unless it
  // changed, so a click never lands on an element that is being replaced.
  FleetMap.prototype.tick = function () {
    var self = this;
    Object.keys(this.markers).forEach(function (slug) {
      var v = self.vessels[slug], st = self.state(v), node = self.markers[slug].getElement();
      if (!node) { return; }
      var html = self.markerHtml(v, st);
      if (node.shoresideHtml !== html) { node.innerHTML = html; node.shoresideHtml = html; }
      var age = node.querySelector(".vessel-age");
      age.textContent = st.fixAge === null ? "" : S.fmtDuration(st.fixAge);
      age.title = v.last_fix ? "last fix " + S.fmtTime(v.last_fix.time) : "";
      node.setAttribute("data-slug", slug);
      node.setAttribute("data-status", st.status);
      L.DomUtil[slug === self.selected ? "addClass" : "removeClass"](node, "selected");
    });
    var key = JSON.stringify([this.selected, this.version, this.overlays.version, this.order.map(function (slug) {
      return self.state(self.vessels[slug]).status;
    })]);
    if (key !== this.headKey) { this.headKey = key; this.renderHead(); }
    this.list.render();
    this.alerts.renderPanel(this.alertsBox, this.selected);
    this.renderMission();
    this.updateAges();
    S.fleetConsole.declutter(this);
  };

  // New trails or missions: the list and the panel show the missions' progress.
  FleetMap.prototype.overlaysChanged = function () { this.tick(); };

  // The selected vessel's mission, rebuilt only when what it says changes.
  FleetMap.prototype.renderMission = function () {
    var box = this.overlays.missionBox(this.selected);
    var key = box ? box.outerHTML : "";
    if (key === this.missionKey) { return; }
    this.missionKey = key;
    this.missionBox.innerHTML = "";
    if (box) { this.missionBox.appendChild(box); }
  };

  FleetMap.prototype.ageSpan = function (since, suffix) {
    return el("span", { class: "age", "data-since": since, "data-suffix": suffix || "", title: S.fmtTime(since) });
  };

  FleetMap.prototype.updateAges = function () {
    var now = this.now();
    this.panel.querySelectorAll(".age[data-since]").forEach(function (span) {
      span.textContent = S.fmtDuration((now - Date.parse(span.dataset.since)) / 1000) + span.dataset.suffix;
    });
  };

  FleetMap.prototype.select = function (slug, options) {
    this.selected = slug;
    this.pending = null;
    this.pick = null;
    this.message = null;
    this.commands = null;
    this.commandsKey = null;
    this.overlay.clearLayers();
    this.targets.clearLayers();
    L.DomUtil.removeClass(this.map.getContainer(), "picking");
    this.tick();
    this.renderActions();
    this.renderCommands();
    this.overlays.drawAll(); // the selected vessel's mission is drawn stronger, its waypoint named
    this.body.scrollTop = 0;
    if (slug) {
      var marker = this.markers[slug];
      var centre = options && options.centre;
      if (marker && (centre || !this.map.getBounds().contains(marker.getLatLng()))) { this.map.panTo(marker.getLatLng()); }
      this.pollCommands();
    }
  };

  // --- the panel -------------------------------------------------------------------------

  FleetMap.prototype.renderHead = function () {
    var self = this;
    var box = this.head;
    box.innerHTML = "";
    this.readingsBox.innerHTML = "";
    if (!this.selected) {
      box.appendChild(el("p", { class: "muted help", text: "Click a vessel on the map or in the list for its readings, mission, commands and track." }));
      return;
    }
    var v = this.vessels[this.selected], st = this.state(v), fix = v.last_fix;
    box.appendChild(el("button", { type: "button", class: "link-button back", text: "← Fleet", onclick: function () { self.select(null); } }));
    box.appendChild(el("h2", {}, [v.name, " ", el("span", { class: "status-badge status-" + st.status.replace(" ", "-"), text: st.status })]));
    box.appendChild(el("p", { class: "muted", text: v.kind === "wave_glider" ? "Wave Glider" : "ArduPilot (MAVLink)" }));
    var links = el("p", { class: "panel-links" });
    if (this.cfg.trackUrl) {
      links.appendChild(el("a", { class: "button", href: this.cfg.trackUrl.replace("__slug__", v.slug), text: "Track and plots" }));
    }
    if (v.admin_url) { links.appendChild(el("a", { class: "button", href: v.admin_url, text: "Admin page" })); }
    box.appendChild(links);
    if (!fix) {
      box.appendChild(el("p", { text: "No fix yet: this vessel has never reported." }));
      return;
    }
    box = this.readingsBox;
    box.appendChild(el("h3", { text: "Last fix" }));
    var rows = [
      ["Time", el("span", {}, [S.fmtTime(fix.time) + " (", this.ageSpan(fix.time, " ago"), ")"])],
      ["Position", S.positionEl(fix.lat, fix.lon)],
      ["Speed", S.fmtSpeed(fix.speed_mps)],
      ["Heading", S.fmtHeading(fix.heading_deg)],
      [this.label("battery_v"), S.fmtValue(fix.battery_v, this.unit("battery_v"))],
    ];
    var endurance = this.overlays.endurance[v.slug];
    if (endurance) { rows.push(["Endurance", endurance.text]); }
    var readings = fix.readings || {};
    S.readingKeys(readings, this.cfg.channels).forEach(function (key) {
      rows.push([self.label(key), S.fmtReading(key, readings[key], self.cfg.channels)]);
    });
    var table = el("table", { class: "readings" });
    rows.forEach(function (r) {
      var value = typeof r[1] === "string" ? el("td", { text: r[1] }) : el("td", {}, [r[1]]);
      table.appendChild(el("tr", {}, [el("th", { text: r[0] }), value]));
    });
    box.appendChild(table);
  };

  FleetMap.prototype.label = function (key) {
    var c = this.cfg.channels[key];
    return c ? c.label : key;
  };
  FleetMap.prototype.unit = function (key) {
    var c = this.cfg.channels[key];
    return c ? c.unit : "";
  };

  S.FleetMap = FleetMap; // fleet_commands.js adds the command actions

  window.ShoresideFleetMap = function (map) {
    S.baseMap(map);
    window.shoresideFleet = new FleetMap(map, S.json("fleet-map-config"));
  };
})();
