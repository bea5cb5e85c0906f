// Commands from the fleet map (issue 9 §4): the selected vessel's actions (a point picked on
// the map, a typed heading), the confirmation, the send through the operator command API, its
// recent commands moving through their states, and cancelling; methods of fleet_map.js's
// FleetMap (loaded before this file).
(function () {
  "use strict";
  var S = window.Shoreside;
  var el = S.el;
  var FleetMap = S.FleetMap;
  var COMMANDS_POLL_MS = 3000;
  // A move_to farther than this is warned about in the confirmation: a boat's usual move is a
  // few hundred metres; the server refuses past the vessel's limit (MOVE_TO_MAX_M, 5 km).
  var MOVE_WARN_M = 2000;
  // A command's relay (docs/links.md#routing-per-vessel), as its line in the list says it.
  var RELAYED = { sms: "SMS", sbd: "Iridium SBD" };

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
      var urgent = el("input", { type: "checkbox", class: "urgent", onchange: function (e) { self.pending.urgent = e.target.checked; } });
      urgent.checked = !!this.pending.urgent;  // an attribute would tick it whatever its value
      var confirmBox = box.appendChild(el("div", { class: "confirm-box" }, [
        el("p", { class: "confirm-text", text: this.pending.text }),
        this.pending.warning ? el("p", { class: "confirm-warning", text: this.pending.warning }) : null,
        // Urgent: the shore also sends it at once by the vessel's SMS or Iridium SBD link
        // (docs/links.md#routing-per-vessel), which costs per message.
        el("label", { class: "confirm-urgent small" }, [
          urgent,
          " urgent: also by SMS or Iridium SBD at once, if it has one",
        ]),
        el("br"),
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
      body: JSON.stringify({ kind: pending.kind, params: pending.params, source: "map", urgent: !!pending.urgent }),
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
        el("span", { class: "muted small" }, [self.ageSpan(c.created_at, " ago"), (c.created_by ? " by " + c.created_by : "") + " via " + c.source + (c.urgent ? " · urgent" : "") + (RELAYED[c.relay] ? " · also sent by " + RELAYED[c.relay] : "") + (c.result_detail ? " · " + c.result_detail : "")]),
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
})();
