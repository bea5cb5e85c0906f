// Open alerts and fences on the fleet map (issue 19): a red badge on each vessel with open
// alerts (orange when all are acknowledged), the same badge in the list, the selected vessel's
// alerts in its panel with an Acknowledge button (POST /api/v1/alerts/<id>/ack/), and the
// fences drawn on the map (green: stay inside; red, dashed: stay out).
//
// Alerts come from /api/v1/fleet/alerts/, polled as often as the fleet (with If-None-Match):
// an alert is what an operator must see at once. Fences come with the overlays.
(function () {
  "use strict";
  var S = window.Shoreside;
  var el = S.el;
  var FENCE = { inclusion: "#2e7d32", exclusion: "#c62828" };

  function Alerts(fleet) {
    this.fleet = fleet;
    this.cfg = fleet.cfg;
    this.list = [];
    this.byVessel = {};
    this.etag = null;
    this.polls = 0; // answered polls, for the browser tests
    this.message = null;
    this.panelKey = null;
    if (!this.cfg.alertsUrl) { return; }
    var self = this;
    document.addEventListener("visibilitychange", function () { if (!document.hidden) { self.poll(); } });
    this.poll();
  }

  Alerts.prototype.poll = function () {
    var self = this;
    clearTimeout(this.timer);
    if (this.inFlight) { this.again = true; return; } // once the one in flight is answered
    if (document.hidden) { return; }
    this.inFlight = true;
    var headers = this.etag ? { "If-None-Match": this.etag } : {};
    S.getJSON(this.cfg.alertsUrl, headers)
      .then(function (r) {
        if (r.status === 304) { return null; }
        if (!r.ok) { throw new Error("HTTP " + r.status); }
        self.etag = r.headers.get("ETag");
        return r.json();
      })
      .then(function (data) {
        self.polls += 1;
        if (data) { self.load(data.alerts); }
      })
      .catch(function () { self.etag = null; }) // the fleet poll reports a dead link
      .then(function () {
        self.inFlight = false;
        if (self.again) { self.again = false; self.poll(); return; }
        self.timer = setTimeout(function () { self.poll(); }, self.cfg.pollS * 1000);
      });
  };

  Alerts.prototype.load = function (alerts) {
    var byVessel = {};
    alerts.forEach(function (a) { (byVessel[a.vessel] = byVessel[a.vessel] || []).push(a); });
    this.list = alerts;
    this.byVessel = byVessel;
    this.fleet.tick();
  };

  // {open, acknowledged} counts of the vessel's active alerts.
  Alerts.prototype.counts = function (slug) {
    var counts = { open: 0, acknowledged: 0 };
    (this.byVessel[slug] || []).forEach(function (a) { counts[a.state] += 1; });
    return counts;
  };

  // The badge's HTML for a marker or a list row ("" when the vessel has no active alert).
  Alerts.prototype.badgeHtml = function (slug) {
    var c = this.counts(slug);
    if (!c.open && !c.acknowledged) { return ""; }
    var open = c.open > 0;
    var title = open ? c.open + " open alert" + (c.open > 1 ? "s" : "") : c.acknowledged + " acknowledged";
    return el("span", {
      class: "alert-badge " + (open ? "alert-open" : "alert-acknowledged"), title: title,
      "data-count": String(open ? c.open : c.acknowledged), text: String(open ? c.open : c.acknowledged),
    }).outerHTML;
  };

  // The selected vessel's alerts for its panel, rebuilt only when they (or the message) change.
  Alerts.prototype.renderPanel = function (box, slug) {
    var alerts = (slug && this.byVessel[slug]) || [];
    var key = JSON.stringify([slug, alerts, this.message]);
    if (key === this.panelKey) { return; }
    this.panelKey = key;
    box.innerHTML = "";
    if (!slug || (!alerts.length && !this.message)) { return; }
    var self = this;
    box.appendChild(el("h3", { text: "Alerts" }));
    var list = box.appendChild(el("ul", { class: "alert-list" }));
    alerts.forEach(function (a) {
      var item = el("li", { "data-id": String(a.id), "data-state": a.state, class: "alert-item" }, [
        el("span", { class: "status-badge alert-" + a.state, text: a.state }), " ",
        el("b", { text: a.rule }), " ",
        el("span", { class: "alert-detail", text: a.detail || a.kind }), el("br"),
        el("span", { class: "muted small" }, [
          "opened ", self.fleet.ageSpan(a.opened_at, " ago"),
          a.acknowledged_by ? " · acknowledged by " + a.acknowledged_by : "",
        ]),
      ]);
      if (a.state === "open" && self.cfg.canAck) {
        item.appendChild(el("button", {
          type: "button", class: "button ack-alert", text: "Acknowledge",
          onclick: function () { self.ack(a); },
        }));
      }
      list.appendChild(item);
    });
    if (this.message) {
      box.appendChild(el("p", { class: "action-message " + this.message.kind, text: this.message.text }));
    }
    this.fleet.updateAges();
  };

  Alerts.prototype.ack = function (alert) {
    var self = this;
    fetch(this.cfg.ackUrl.replace("__id__", String(alert.id)), {
      method: "POST", credentials: "same-origin",
      headers: { Accept: "application/json", "X-CSRFToken": this.cfg.csrfToken },
    })
      .then(function (r) {
        return r.json().catch(function () { return {}; }).then(function (body) {
          if (r.ok) {
            self.message = { kind: "success", text: "Acknowledged: " + alert.rule };
          } else {
            var said = typeof body.detail === "string" ? body.detail : JSON.stringify(body.detail || body);
            self.message = { kind: "error", text: "Not acknowledged (HTTP " + r.status + "): " + said };
          }
        });
      })
      .catch(function (err) { self.message = { kind: "error", text: "Not acknowledged: " + err }; })
      .then(function () {
        self.etag = null;
        self.poll();
        self.fleet.tick();
      });
  };

  // The fences, redrawn when the overlays bring them (null: no right to see fences).
  function drawFences(overlays, fences) {
    if (!overlays.fenceGroup) { overlays.fenceGroup = L.layerGroup().addTo(overlays.map); }
    var group = overlays.fenceGroup;
    group.clearLayers();
    (fences || []).forEach(function (f) {
      var colour = f.inclusion ? FENCE.inclusion : FENCE.exclusion;
      var style = {
        color: colour, weight: 2, opacity: 0.9, fillOpacity: 0.06, dashArray: f.inclusion ? null : "6 5",
        interactive: true, className: "fence " + (f.inclusion ? "fence-inclusion" : "fence-exclusion"),
      };
      var layer = null;
      if (f.geometry.type === "Polygon") {
        var ring = f.geometry.coordinates[0].slice(0, -1).map(function (p) { return [p[1], p[0]]; });
        layer = L.polygon(ring, style);
      } else if (f.geometry.type === "Point") {
        layer = L.circle([f.geometry.coordinates[1], f.geometry.coordinates[0]], L.extend({ radius: f.radius_m }, style));
      }
      if (!layer) { return; }
      layer.bindTooltip(f.name + (f.inclusion ? " (stay inside)" : " (stay out)") + (f.vessel ? "" : ", every vessel"));
      layer.addTo(group);
      var path = layer.getElement();
      if (path) { path.setAttribute("data-fence", String(f.id)); }
    });
    group.eachLayer(function (layer) { layer.bringToBack(); });
  }

  S.fleetConsole = S.fleetConsole || {};
  S.fleetConsole.Alerts = Alerts;
  S.fleetConsole.drawFences = drawFences;
})();
