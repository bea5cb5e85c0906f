// The fleet map (issue 9 §1, §4; issue 18 §2): every vessel at its last position, an arrow
// for its heading, coloured by state, labelled with its name and the age of its last fix; it
// polls /api/v1/fleet/ with If-None-Match and never moves the operator's view after the first
// fit. Beside it, the list of vessels (state, age, battery, mission progress); clicking one
// there or on the map opens the side panel: readings with units, its mission, its commands
// moving through their states, links, and the command actions (through the operator command
// API). Trails, missions and labels that give way: fleet_console.js.
(function () {
  "use strict";
  var S = window.Shoreside;
  var el = S.el;
  var COLOURS = { reporting: "#2e7d32", overdue: "#c62828", "never seen": "#757575" };
  var COMMANDS_POLL_MS = 3000;
  // A move_to farther than this is warned about in the confirmation: a boat's usual move is a
  // few hundred metres; the server refuses past the vessel's limit (MOVE_TO_MAX_M, 5 km).
  var MOVE_WARN_M = 2000;
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

  // --- commands from the map ------------------------------------------------------------

  FleetMap.prototype.actionsFor = function (v) { return this.cfg.actions[v.kind] || []; };

  FleetMap.prototype.renderActions = function () {
    var self = this;
    var box = this.actionsBox;
    box.innerHTML = "";
    if (!this.selected) { return; }
    var v = this.vessels[this.selected];
    var actions = this.actionsFor(v);
    if (!actions.length) { return; }
    box.appendChild(el("h3", { text: "Command" }));
    var buttons = el("div", { class: "action-buttons" });
    actions.forEach(function (a) {
      if (a.input === "choice") {
        a.choices.forEach(function (choice) {
          var params = {};
          params[a.param] = choice;
          buttons.appendChild(self.actionButton(a.kind, a.label + ": " + choice, function () {
            self.ask(a, params, "Queue “" + a.label + ": " + choice + "” for " + v.name + "?");
          }));
        });
      } else if (a.input === "point" || a.input === "bearing") {
        buttons.appendChild(self.actionButton(a.kind, a.label + "…", function () { self.startPick(a); }));
      } else {
        buttons.appendChild(self.actionButton(a.kind, a.label, function () {
          self.ask(a, {}, "Queue “" + a.label + "” for " + v.name + "?");
        }));
      }
    });
    box.appendChild(buttons);
    if (this.pick && !this.pending) { // once a point is picked, the confirmation says it all
      var hint = this.pick.input === "point"
        ? "Click the map where " + v.name + " should go (Esc cancels)."
        : "Click a point: " + v.name + " will hold the bearing towards it (Esc cancels). Or type one:";
      var pickBox = el("div", { class: "pick-hint" }, [el("p", { text: hint })]);
      if (this.pick.input === "bearing") {
        var input = el("input", { type: "number", min: String(this.pick.action.min), max: String(this.pick.action.max), step: "1", name: "bearing", class: "vTextField bearing-input" });
        input.value = this.pick.typed || "";
        pickBox.appendChild(el("p", {}, [input, " ° ", el("button", { type: "button", class: "button use-bearing", text: "Use", onclick: function () {
          self.typedBearing(input.value);
        } })]));
      }
      pickBox.appendChild(el("button", { type: "button", class: "link-button", text: "Cancel", onclick: function () { self.cancelPick(); } }));
      box.appendChild(pickBox);
    }
    if (this.pending) {
      var confirmBox = box.appendChild(el("div", { class: "confirm-box" }, [
        el("p", { class: "confirm-text", text: this.pending.text }),
        this.pending.warning ? el("p", { class: "confirm-warning", text: this.pending.warning }) : null,
        el("button", { type: "button", class: "button default confirm-queue", text: "Queue", onclick: function () { self.send(); } }),
        " ",
        el("button", { type: "button", class: "button confirm-cancel", text: "Cancel", onclick: function () { self.cancelPick(); } }),
      ]));
      confirmBox.scrollIntoView({ block: "nearest" });
    }
    if (this.message) {
      box.appendChild(el("p", { class: "action-message " + this.message.kind, text: this.message.text }));
    }
  };

  FleetMap.prototype.actionButton = function (kind, text, onclick) {
    return el("button", { type: "button", class: "button action", "data-kind": kind, text: text, onclick: onclick });
  };

  FleetMap.prototype.startPick = function (action) {
    this.pick = { action: action, input: action.input };
    this.pending = null;
    this.message = null;
    this.overlay.clearLayers();
    L.DomUtil.addClass(this.map.getContainer(), "picking");
    this.renderActions();
  };

  FleetMap.prototype.cancelPick = function () {
    this.pick = null;
    this.pending = null;
    this.overlay.clearLayers();
    L.DomUtil.removeClass(this.map.getContainer(), "picking");
    this.renderActions();
  };

  FleetMap.prototype.ask = function (action, params, text) {
    this.pending = { kind: action.kind, label: action.label, params: params, text: text };
    this.message = null;
    this.renderActions();
  };

  FleetMap.prototype.mapClicked = function (latlng) {
    if (!this.pick || !this.selected) { return; }
    var v = this.vessels[this.selected], fix = v.last_fix, action = this.pick.action;
    this.overlay.clearLayers();
    if (fix) {
      L.polyline([[fix.lat, fix.lon], latlng], { color: "#1565c0", weight: 2, dashArray: "6 6", interactive: false }).addTo(this.overlay);
    }
    L.circleMarker(latlng, { radius: 7, color: "#1565c0", weight: 2, fillOpacity: 0.3, interactive: false }).addTo(this.overlay);
    if (this.pick.input === "point") {
      var where = S.fmtPosition(latlng.lat, latlng.lng) + " (" + S.fmtDDM(latlng.lat, latlng.lng) + ")";
      var text = "Move " + v.name + " to " + where + "?";
      var warning = null;
      if (fix) {
        var d = S.geo.distance(fix.lat, fix.lon, latlng.lat, latlng.lng);
        var b = S.geo.bearing(fix.lat, fix.lon, latlng.lat, latlng.lng);
        text += " " + S.fmtDistance(d) + " at " + pad3(Math.round(b) % 360) + "° from its last position.";
        if (d > MOVE_WARN_M) { warning = "This is " + S.fmtDistance(d) + " away — far beyond a normal move."; }
      } else {
        text += " (its position is unknown: no fix yet)";
        warning = "With no fix, how far this is cannot be checked: the server refuses it unless " + v.name + "'s move_to limit is off (0).";
      }
      this.pending = { kind: action.kind, label: action.label, text: text, warning: warning,
        params: { lat: round6(latlng.lat), lon: round6(latlng.lng) } };
      this.renderActions();
    } else if (this.pick.input === "bearing") {
      if (!fix) { this.message = { kind: "error", text: "No position yet: type the bearing instead." }; this.renderActions(); return; }
      var bearing = Math.round(S.geo.bearing(fix.lat, fix.lon, latlng.lat, latlng.lng)) % 360;
      this.askBearing(action, bearing, S.geo.distance(fix.lat, fix.lon, latlng.lat, latlng.lng));
    }
  };

  // A typed heading is sent as typed or not at all: 400 once wrapped to 040° and the boat
  // turned the wrong way. The range is the catalog's (the action's min and max, whole degrees).
  FleetMap.prototype.typedBearing = function (raw) {
    var text = String(raw).trim(), value = Number(text), lo = this.pick.action.min, hi = this.pick.action.max;
    this.pick.typed = text;
    if (text === "" || !Number.isInteger(value) || value < lo || value > hi) {
      this.message = { kind: "error", text: "A heading is a whole number of degrees from " + lo + " to " + hi +
        (text ? " (you typed " + text + ")." : ".") };
      this.renderActions();
      return;
    }
    this.message = null;
    this.askBearing(this.pick.action, value, null);
  };

  FleetMap.prototype.askBearing = function (action, bearing, distance) {
    var v = this.vessels[this.selected];
    var text = "Queue “" + action.label + " " + pad3(bearing) + "°” for " + v.name + "?";
    if (distance !== null) { text += " (towards the clicked point, " + S.fmtDistance(distance) + " away)"; }
    var params = {};
    params[action.param] = bearing;
    this.pending = { kind: action.kind, label: action.label, params: params, text: text };
    this.renderActions();
  };

  FleetMap.prototype.send = function () {
    var self = this, pending = this.pending, slug = this.selected;
    if (!pending || !slug) { return; }
    fetch(this.cfg.commandsUrl.replace("__slug__", slug), {
      method: "POST",
      credentials: "same-origin",
      headers: { "Content-Type": "application/json", Accept: "application/json", "X-CSRFToken": this.cfg.csrfToken },
      // source "map": the history says the command came from the map, not a script.
      body: JSON.stringify({ kind: pending.kind, params: pending.params, source: "map" }),
    })
      .then(function (r) { return r.json().catch(function () { return {}; }).then(function (body) { return { r: r, body: body }; }); })
      .then(function (res) {
        if (res.r.status === 201) {
          self.message = { kind: "success", text: "Queued: " + pending.label + " (" + res.body.uid.slice(0, 8) + "…)" };
          self.pick = null;
          self.pending = null;
          self.overlay.clearLayers();
          self.revealCommands = true; // the new command, in view as it moves through its states
          L.DomUtil.removeClass(self.map.getContainer(), "picking");
          self.pollCommands();
        } else {
          self.message = { kind: "error", text: "Not queued (HTTP " + res.r.status + "): " + describe(res.body) };
        }
        self.renderActions();
      })
      .catch(function (err) {
        self.message = { kind: "error", text: "Not queued: " + err };
        self.renderActions();
      });
  };

  FleetMap.prototype.cancelCommand = function (uid, kind) {
    var self = this;
    fetch(this.cfg.cancelUrl.replace("__uid__", uid), {
      method: "POST", credentials: "same-origin",
      headers: { Accept: "application/json", "X-CSRFToken": this.cfg.csrfToken },
    }).then(function (r) {
      if (!r.ok) {
        return r.json().catch(function () { return {}; }).then(function (body) {
          self.message = { kind: "error", text: "Not cancelled (HTTP " + r.status + "): " + describe(body) };
          self.renderActions();
        });
      }
      self.message = { kind: "success", text: "Cancelled: " + kind + " (" + uid.slice(0, 8) + "…)" };
      self.renderActions();
      self.pollCommands();
    });
  };

  // The vessel's newest commands, polled while its panel is open: each one's state moves on
  // as the boat polls, acks and finishes it.
  FleetMap.prototype.pollCommands = function () {
    var self = this, slug = this.selected;
    clearTimeout(this.commandsTimer);
    if (!slug || !this.cfg.canViewCommands) { return; }
    var url = this.cfg.commandsUrl.replace("__slug__", slug) + "?page_size=" + this.cfg.panelCommands;
    S.getJSON(url)
      .then(function (r) { return r.ok ? r.json() : null; })
      .then(function (data) {
        if (self.selected !== slug) { return; }
        var commands = data ? data.results : null, key = JSON.stringify(commands);
        if (key === self.commandsKey) { return; } // unchanged: keep the list (and its buttons)
        self.commandsKey = key;
        self.commands = commands;
        self.renderCommands();
      })
      .catch(function () {})
      .then(function () {
        if (self.selected === slug) { self.commandsTimer = setTimeout(function () { self.pollCommands(); }, COMMANDS_POLL_MS); }
      });
  };

  // The open move_to commands' targets, with a dashed line from where the vessel is now.
  FleetMap.prototype.drawTargets = function () {
    var self = this, v = this.vessels[this.selected], fix = v && v.last_fix;
    this.targets.clearLayers();
    (this.commands || []).forEach(function (c) {
      if (c.kind !== "move_to" || self.cfg.statuses.unfinished.indexOf(c.status) < 0) { return; }
      var target = [c.params.lat, c.params.lon];
      if (fix) {
        L.polyline([[fix.lat, fix.lon], target], { color: "#00838f", weight: 2, dashArray: "4 6", interactive: false }).addTo(self.targets);
      }
      L.circleMarker(target, { radius: 7, color: "#00838f", weight: 2, fillOpacity: 0.2, interactive: false })
        .bindTooltip("move_to: " + c.status).addTo(self.targets);
    });
  };

  FleetMap.prototype.renderCommands = function () {
    var self = this, box = this.commandsBox;
    box.innerHTML = "";
    this.drawTargets();
    if (!this.selected || !this.cfg.canViewCommands) { return; }
    box.appendChild(el("h3", { text: "Recent commands" }));
    if (this.commands === null) { box.appendChild(el("p", { class: "muted", text: "loading…" })); return; }
    if (!this.commands.length) { box.appendChild(el("p", { class: "muted", text: "None yet." })); return; }
    var list = el("ul", { class: "command-list" });
    this.commands.forEach(function (c) {
      var item = el("li", { "data-uid": c.uid, "data-status": c.status, class: self.cfg.statuses.unfinished.indexOf(c.status) >= 0 ? "open" : "closed" }, [
        el("span", { class: "status-badge cmd-" + c.status, text: c.status }),
        " ",
        el("b", { text: c.kind }),
        " ",
        el("span", { class: "muted", text: summary(c.params) }),
        el("br"),
        el("span", { class: "muted small" }, [self.ageSpan(c.created_at, " ago"), (c.created_by ? " by " + c.created_by : "") + " via " + c.source + (c.result_detail ? " · " + c.result_detail : "")]),
      ]);
      if (self.cfg.canCancel && self.cfg.statuses.cancellable.indexOf(c.status) >= 0) {
        item.appendChild(el("button", { type: "button", class: "link-button cancel-command", text: "cancel", onclick: function () { self.cancelCommand(c.uid, c.kind); } }));
      }
      list.appendChild(item);
    });
    box.appendChild(list);
    this.updateAges();
    if (this.revealCommands) { this.revealCommands = false; box.scrollIntoView({ block: "nearest" }); }
  };

  function summary(params) {
    if (!params) { return ""; }
    if (params.items) { return params.items.length + " items"; }
    if (typeof params.lat === "number" && typeof params.lon === "number") { return S.fmtPosition(params.lat, params.lon); }
    return Object.keys(params).map(function (k) {
      var v = params[k];
      return k + " " + (typeof v === "number" ? +v.toFixed(5) : v);
    }).join(", ");
  }

  // The API's error body as a sentence: {"detail": {"params": ["…"]}} reads "…".
  function describe(body) {
    if (!body) { return "no detail"; }
    var detail = body.detail !== undefined ? body.detail : body;
    if (typeof detail === "string") { return detail; }
    if (detail && typeof detail === "object" && !Array.isArray(detail)) {
      return Object.keys(detail).map(function (field) {
        var said = [].concat(detail[field]).join(" ");
        return field === "params" || field === "non_field_errors" ? said : field + ": " + said;
      }).join("; ");
    }
    return JSON.stringify(detail);
  }

  function pad3(n) { return ("00" + n).slice(-3); }
  function round6(x) { return Math.round(x * 1e6) / 1e6; }

  window.ShoresideFleetMap = function (map) {
    S.baseMap(map);
    window.shoresideFleet = new FleetMap(map, S.json("fleet-map-config"));
  };
})();
