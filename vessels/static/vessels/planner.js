// The mission planner (issue 9 §5) on the Mission change page. The inline item rows stay the
// form that is saved (seq, lat, lon, hold_s, radius_m, speed_mps); this script edits them from
// the map and draws them: click to add at the end, drag to move, delete and reorder in the
// list. Per-leg and total distance and time at the vessel's cruise speed (a speed change holds
// from its item on); the end (stop, loop, return home) is drawn as the closing leg.
(function () {
  "use strict";
  var S = window.Shoreside;
  var el = S.el;
  var PREFIX = "items";
  var COORD_DIGITS = 6; // ~0.1 m: finer than any GPS fix
  // A template mission (no vessel) is timed at vessels/missions.py's DEFAULT_CRUISE_SPEED_MPS.
  var DEFAULT_CRUISE_SPEED_MPS = 1.5;

  function Planner(map) {
    this.map = map;
    this.group = document.getElementById(PREFIX + "-group");
    this.editable = !!(this.group && this.group.querySelector('input[name$="-lat"]'));
    this.layer = L.layerGroup().addTo(map);
    this.selected = null;
    this.list = document.getElementById("planner-list");
    var self = this;
    if (this.editable) {
      map.on("click", function (e) { self.add(e.latlng); });
      var rerender = function () { self.schedule(); };
      document.addEventListener("input", rerender);
      document.addEventListener("change", rerender);
      document.addEventListener("formset:added", rerender);
      document.addEventListener("formset:removed", rerender);
      var vessel = input("id_vessel");
      if (vessel) { vessel.addEventListener("change", function () { if (!self.items().length) { self.fit(); } }); }
    }
    this.render();
    this.fit();
  }

  // --- the rows (the form) ---------------------------------------------------------------

  function field(row, name) { return row.querySelector('[name$="-' + name + '"]'); }
  function num(input) {
    if (!input || input.value === "") { return null; }
    var v = parseFloat(input.value);
    return isNaN(v) ? null : v;
  }

  Planner.prototype.rows = function () {
    if (!this.group) { return []; }
    return Array.prototype.slice.call(this.group.querySelectorAll("tr.form-row:not(.empty-form)"))
      .filter(function (row) { return field(row, "lat"); });
  };

  // The mission's items: live rows with a position, in seq order (rows without one yet are
  // the inline's blank extras).
  Planner.prototype.items = function () {
    if (!this.editable) { return this.savedItems(); }
    var items = [];
    this.rows().forEach(function (row, index) {
      var del = field(row, "DELETE");
      if (del && del.checked) { return; }
      var lat = num(field(row, "lat")), lon = num(field(row, "lon"));
      if (lat === null || lon === null) { return; }
      items.push({
        row: row, index: index, lat: lat, lon: lon,
        seq: num(field(row, "seq")), hold: num(field(row, "hold_s")) || 0,
        radius: num(field(row, "radius_m")), speed: num(field(row, "speed_mps")),
      });
    });
    items.sort(function (a, b) {
      var sa = a.seq === null ? Infinity : a.seq, sb = b.seq === null ? Infinity : b.seq;
      return sa - sb || a.index - b.index;
    });
    return items;
  };

  Planner.prototype.savedItems = function () {
    return Array.prototype.map.call(document.querySelectorAll("#planner-saved-items li"), function (li) {
      function f(k) { return li.dataset[k] === "" ? null : parseFloat(li.dataset[k]); }
      return { row: null, lat: f("lat"), lon: f("lon"), seq: f("seq"), hold: f("hold") || 0, radius: f("radius"), speed: f("speed") };
    });
  };

  Planner.prototype.renumber = function (items) {
    items.forEach(function (item, i) { field(item.row, "seq").value = String(i + 1); });
  };

  // A blank extra row if there is one, else a new one from Django's "Add another" link.
  Planner.prototype.freeRow = function () {
    var blank = this.rows().filter(function (row) {
      return !row.classList.contains("has_original") && num(field(row, "lat")) === null && num(field(row, "lon")) === null;
    })[0];
    if (blank) { return blank; }
    var add = this.group.querySelector(".add-row a");
    if (!add) { return null; }
    add.click();
    var rows = this.rows();
    return rows[rows.length - 1];
  };

  Planner.prototype.add = function (latlng) {
    var items = this.items();
    var row = this.freeRow();
    if (!row) { return; }
    field(row, "lat").value = latlng.lat.toFixed(COORD_DIGITS);
    field(row, "lon").value = latlng.lng.toFixed(COORD_DIGITS);
    var hold = field(row, "hold_s");
    if (hold && hold.value === "") { hold.value = "0"; }
    field(row, "seq").value = String(items.length + 1);
    this.renumber(items.concat([{ row: row }]));
    this.selected = row;
    this.render();
  };

  Planner.prototype.move = function (item, latlng) {
    field(item.row, "lat").value = latlng.lat.toFixed(COORD_DIGITS);
    field(item.row, "lon").value = latlng.lng.toFixed(COORD_DIGITS);
    this.selected = item.row;
    this.render();
  };

  Planner.prototype.remove = function (item) {
    var items = this.items().filter(function (i) { return i.row !== item.row; });
    var del = field(item.row, "DELETE");
    if (del) {
      del.checked = true; // a saved item: deleted on save
    } else {
      var link = item.row.querySelector(".inline-deletelink");
      if (link) { link.click(); } else { field(item.row, "lat").value = ""; field(item.row, "lon").value = ""; }
    }
    this.renumber(items);
    this.render();
  };

  Planner.prototype.shift = function (item, by) {
    var items = this.items();
    var i = items.findIndex(function (x) { return x.row === item.row; }), j = i + by;
    if (j < 0 || j >= items.length) { return; }
    var tmp = items[i]; items[i] = items[j]; items[j] = tmp;
    this.renumber(items);
    this.selected = item.row;
    this.render();
  };

  // --- the mission's settings ---------------------------------------------------------------

  function input(id) { return document.getElementById(id); }

  Planner.prototype.end = function () {
    var end = input("id_end"), loop = input("id_loop"), saved = document.getElementById("planner-saved-mission").dataset;
    if (end) { return end.value || "stop"; }
    if (loop) { return loop.checked ? "loop" : "stop"; }
    return saved.end || (saved.loop ? "loop" : "stop");
  };

  Planner.prototype.home = function () {
    var saved = document.getElementById("planner-saved-mission").dataset;
    var lat = input("id_home_lat") ? num(input("id_home_lat")) : (saved.homeLat === "" ? null : parseFloat(saved.homeLat));
    var lon = input("id_home_lon") ? num(input("id_home_lon")) : (saved.homeLon === "" ? null : parseFloat(saved.homeLon));
    return lat === null || lon === null ? null : [lat, lon];
  };

  Planner.prototype.vessel = function () {
    var select = input("id_vessel");
    var selector = select ? 'li[data-id="' + select.value + '"]' : "li[data-current]";
    var li = document.querySelector("#planner-vessels " + selector);
    if (!li) { return null; }
    var d = li.dataset;
    return {
      name: d.name, cruise: d.cruise === "" ? null : parseFloat(d.cruise),
      at: d.lat === "" || d.lon === "" ? null : [parseFloat(d.lat), parseFloat(d.lon)],
    };
  };

  // --- drawing ---------------------------------------------------------------------------

  Planner.prototype.schedule = function () {
    var self = this;
    if (this.pendingFrame) { return; }
    this.pendingFrame = requestAnimationFrame(function () { self.pendingFrame = null; self.render(); });
  };

  // Legs as vessels/missions.py counts them: an item's speed is the speed of the leg *to* it
  // and of every leg after (DO_CHANGE_SPEED runs as the boat sets off toward that waypoint).
  Planner.prototype.legs = function (items, cruise) {
    var speed = (items[0] && items[0].speed) || cruise, legs = [null];
    for (var n = 1; n < items.length; n++) {
      speed = items[n].speed || speed;
      var d = S.geo.distance(items[n - 1].lat, items[n - 1].lon, items[n].lat, items[n].lon);
      legs.push({ distance: d, speed: speed, time: d / speed });
    }
    return { legs: legs, speed: speed, loopSpeed: (items[0] && items[0].speed) || speed };
  };

  Planner.prototype.render = function () {
    var self = this, items = this.items(), vessel = this.vessel(), end = this.end(), home = this.home();
    var cruise = (vessel && vessel.cruise) || DEFAULT_CRUISE_SPEED_MPS;
    var plan = this.legs(items, cruise);
    this.layer.clearLayers();
    var path = items.map(function (i) { return [i.lat, i.lon]; });
    if (path.length > 1) { L.polyline(path, { color: "#1565c0", weight: 3, interactive: false }).addTo(this.layer); }
    var closing = null;
    if (items.length && end === "loop" && items.length > 1) { closing = [items[items.length - 1], items[0]]; }
    if (items.length && end === "return_home" && home) { closing = [items[items.length - 1], { lat: home[0], lon: home[1] }]; }
    var closeLeg = null;
    if (closing) {
      L.polyline([[closing[0].lat, closing[0].lon], [closing[1].lat, closing[1].lon]],
        { color: "#1565c0", weight: 2, dashArray: "6 6", interactive: false }).addTo(this.layer);
      var cd = S.geo.distance(closing[0].lat, closing[0].lon, closing[1].lat, closing[1].lon);
      var closeSpeed = end === "loop" ? plan.loopSpeed : plan.speed;
      closeLeg = { distance: cd, time: cd / closeSpeed };
    }
    if (home) {
      L.marker(home, { interactive: false, icon: L.divIcon({ className: "home-icon", html: "H", iconSize: [20, 20], iconAnchor: [10, 10] }) })
        .addTo(this.layer);
    }
    if (vessel && vessel.at) {
      L.circleMarker(vessel.at, { radius: 5, color: "#555", fillOpacity: 0.6, interactive: false })
        .bindTooltip(el("span", { text: vessel.name + " (last fix)" })).addTo(this.layer);
    }
    items.forEach(function (item, i) {
      var marker = L.marker([item.lat, item.lon], {
        draggable: self.editable, autoPan: true, title: "waypoint " + (i + 1),
        icon: L.divIcon({
          className: "waypoint-icon" + (item.row && item.row === self.selected ? " selected" : ""),
          html: String(i + 1), iconSize: [22, 22], iconAnchor: [11, 11],
        }),
      }).addTo(self.layer);
      marker.on("click", function (e) { L.DomEvent.stopPropagation(e); self.select(item.row); });
      marker.on("dragend", function () { self.move(item, marker.getLatLng()); });
      if (item.radius) {
        L.circle([item.lat, item.lon], { radius: item.radius, color: "#1565c0", weight: 1, fillOpacity: 0.05, interactive: false }).addTo(self.layer);
      }
    });
    this.renderList(items, plan.legs, closeLeg, end, cruise);
    this.rows().forEach(function (row) { row.classList.toggle("planner-selected", row === self.selected); });
  };

  Planner.prototype.select = function (row) {
    this.selected = row;
    this.render();
    if (row) { row.scrollIntoView({ block: "nearest" }); }
  };

  Planner.prototype.renderList = function (items, legs, closeLeg, end, cruise) {
    var self = this, box = this.list;
    box.innerHTML = "";
    var head = el("tr", {}, ["#", "position", "leg", "time", "hold", "speed", ""].map(function (h) { return el("th", { text: h }); }));
    var table = el("table", { class: "planner-items" }, [head]);
    var totalD = 0, totalT = 0, timeKnown = true, holds = 0;
    items.forEach(function (item, i) {
      var leg = legs[i];
      if (leg) { totalD += leg.distance; if (leg.time === null) { timeKnown = false; } else { totalT += leg.time; } }
      holds += item.hold;
      var buttons = el("td", { class: "planner-buttons" });
      if (self.editable) {
        buttons.appendChild(el("button", { type: "button", title: "earlier", text: "↑", class: "planner-up", onclick: function () { self.shift(item, -1); } }));
        buttons.appendChild(el("button", { type: "button", title: "later", text: "↓", class: "planner-down", onclick: function () { self.shift(item, 1); } }));
        buttons.appendChild(el("button", { type: "button", title: "delete", text: "✕", class: "planner-delete", onclick: function () { self.remove(item); } }));
      }
      var tr = el("tr", { class: item.row && item.row === self.selected ? "selected" : "", "data-index": String(i + 1) }, [
        el("td", { text: String(i + 1) }),
        el("td", { text: S.fmtLatLon(item.lat, item.lon), class: "planner-position" }),
        el("td", { text: leg ? S.fmtDistance(leg.distance) : "start" }),
        el("td", { text: leg ? S.fmtDuration(leg.time) : "" }),
        el("td", { text: item.hold ? S.fmtDuration(item.hold) : "" }),
        el("td", { text: item.speed === null ? "" : item.speed + " m/s" }),
        buttons,
      ]);
      tr.addEventListener("click", function (e) { if (e.target.tagName !== "BUTTON") { self.select(item.row); } });
      table.appendChild(tr);
    });
    if (!items.length) {
      table.appendChild(el("tr", {}, [el("td", { colspan: "7", class: "muted", text: self.editable ? "No waypoints yet: click the map." : "No waypoints." })]));
    }
    box.appendChild(table);
    var endText = { stop: "Then it stops at the last waypoint.", loop: "Then it loops back to waypoint 1", return_home: "Then it returns home" }[end] || "";
    if (closeLeg) { endText += " (" + S.fmtDistance(closeLeg.distance) + (closeLeg.time === null ? "" : ", " + S.fmtDuration(closeLeg.time)) + ")."; }
    else if (end !== "stop") { endText += end === "return_home" ? " (home position not set: the autopilot's own home)." : "."; }
    var withClose = totalD + (closeLeg ? closeLeg.distance : 0);
    var timeWithClose = totalT + (closeLeg && closeLeg.time ? closeLeg.time : 0) + holds;
    var speedText = "Times at a cruise speed of " + cruise + " m/s unless an item sets its own";
    box.appendChild(el("div", { class: "planner-totals" }, [
      el("p", { id: "planner-total", text: items.length + " waypoints · " + S.fmtDistance(withClose) +
        (timeKnown ? " · " + S.fmtDuration(timeWithClose) + (end === "loop" ? " per lap" : "") : "") +
        (holds ? " (holds " + S.fmtDuration(holds) + ")" : "") }),
      el("p", { class: "muted", text: speedText + ". " + endText }),
    ]));
  };

  Planner.prototype.fit = function () {
    var items = this.items(), vessel = this.vessel(), home = this.home();
    var points = items.map(function (i) { return [i.lat, i.lon]; });
    if (home) { points.push(home); }
    if (points.length > 1) { this.map.fitBounds(L.latLngBounds(points).pad(0.2), { maxZoom: 16 }); }
    else if (points.length === 1) { this.map.setView(points[0], 15); }
    else if (vessel && vessel.at) { this.map.setView(vessel.at, 14); }
  };

  window.ShoresideMissionPlanner = function (map) {
    S.baseMap(map);
    window.shoresidePlanner = new Planner(map);
  };
})();
