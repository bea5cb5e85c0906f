// The compact list of vessels beside the fleet map (issue 18 §2): name, state, age of the last
// fix, battery and the running mission's progress; a click (or Enter) selects the vessel and
// brings it to the middle of the map. Rows are built once per set of vessels and updated in
// place every second, so a click never lands on a row that is being replaced.
(function () {
  "use strict";
  var S = window.Shoreside;
  var el = S.el;

  function VesselList(fleet, box) {
    this.fleet = fleet;
    this.box = box;
    this.rows = {};
    this.orderKey = null;
  }

  VesselList.prototype.render = function () {
    var self = this, fleet = this.fleet;
    var orderKey = fleet.order.join("\n");
    if (orderKey !== this.orderKey) { this.orderKey = orderKey; this.build(); }
    fleet.order.forEach(function (slug) { self.fill(slug); });
  };

  VesselList.prototype.build = function () {
    var self = this, fleet = this.fleet;
    var table = el("table", { class: "vessel-list" }, [
      el("thead", {}, [el("tr", {}, [
        el("th", { text: "Vessel" }), el("th", { text: "State" }), el("th", { text: "Fix" }), el("th", { text: fleet.label("battery_v") }),
      ])]),
    ]);
    var body = table.appendChild(el("tbody"));
    this.rows = {};
    fleet.order.forEach(function (slug) {
      function choose() { fleet.select(slug, { centre: true }); }
      var row = {
        dot: el("span", { class: "status-dot" }),
        name: el("b"),
        alerts: el("span", { class: "list-alerts" }),
        progress: el("span", { class: "muted small wp-progress" }),
        state: el("td", { class: "state" }),
        age: el("span", { class: "age", "data-suffix": "" }),
        battery: el("td", { class: "battery" }),
      };
      row.tr = body.appendChild(el("tr", {
        "data-slug": slug, tabindex: "0", onclick: choose,
        onkeydown: function (e) { if (e.key === "Enter") { choose(); } },
      }, [
        el("td", { class: "name" }, [row.dot, row.name, row.alerts, row.progress]),
        row.state,
        el("td", { class: "fix-age" }, [row.age]),
        row.battery,
      ]));
      self.rows[slug] = row;
    });
    if (!fleet.order.length) { body.appendChild(el("tr", {}, [el("td", { colspan: "4", class: "muted", text: "No active vessels." })])); }
    this.box.innerHTML = "";
    this.box.appendChild(table);
  };

  function set(node, property, value) {
    if (node[property] !== value) { node[property] = value; }
  }

  VesselList.prototype.fill = function (slug) {
    var fleet = this.fleet, row = this.rows[slug], v = fleet.vessels[slug];
    if (!row || !v) { return; }
    var st = fleet.state(v), fix = v.last_fix;
    set(row.tr, "className", slug === fleet.selected ? "selected" : "");
    set(row.tr, "title", "Show " + v.name);
    set(row.dot, "className", "status-dot status-" + st.status.replace(" ", "-"));
    set(row.name, "textContent", v.name);
    set(row.alerts, "innerHTML", fleet.alerts.badgeHtml(slug));
    var progress = fleet.overlays.progressText(slug);
    set(row.progress, "textContent", progress ? " " + progress.replace("waypoint ", "wp ").replace(" of ", "/") : "");
    set(row.progress, "title", progress || "");
    set(row.state, "textContent", st.status);
    if (fix) {
      if (row.age.dataset.since !== fix.time) { row.age.dataset.since = fix.time; row.age.title = S.fmtTime(fix.time); }
    } else {
      delete row.age.dataset.since;
      set(row.age, "textContent", "—");
    }
    var battery = fix && fix.battery_v !== null && fix.battery_v !== undefined ? S.fmtValue(fix.battery_v, fleet.unit("battery_v")) : "—";
    set(row.battery, "textContent", battery);
  };

  S.fleetConsole = S.fleetConsole || {};
  S.fleetConsole.VesselList = VesselList;
})();
