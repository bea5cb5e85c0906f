// The mission planner (issue 9 §5) on the Mission change page. The inline item rows stay the
// form that is saved (seq, lat, lon, hold_s, radius_m, speed_mps); this script edits them from
// the map and draws them: click to add at the end, drag to move, delete and reorder in the
// list. Per-leg and total distance and time, and the mission checks, are the server's
// (vessels/missions.py review, through the admin's review URL): one computation for this list,
// the route table and a send. A leg that fails a check is drawn red and dashed, a row that does
// (latitude 95, say) says why beside it and stays off the map. The end (stop, loop, return
// home) is drawn as the closing leg, and the way to waypoint 1 (from home, or from the
// vessel's last fix when the mission has no home) as a dashed leg. Each waypoint's hold and
// speed are edited in its row of the list, next to its position (written through to the
// inline row, which stays the form).
(function () {
  "use strict";
  var S = window.Shoreside;
  var el = S.el;
  var PREFIX = "items";
  var COORD_DIGITS = 6; // ~0.1 m: finer than any GPS fix
  // Only for the "times at a cruise speed of" line: a template mission (no vessel) is timed
  // at vessels/missions.py's DEFAULT_CRUISE_SPEED_MPS.
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
  // A field's number, or null when it is empty or not a number: strict (Number, not
  // parseFloat), so a typo like "4o" is no number rather than 4.
  function num(input) {
    if (!input || input.value.trim() === "") { return null; }
    var v = Number(input.value.trim());
    return isFinite(v) ? v : null;
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

  // A position the map can draw: anything else stays off the map, its row marked by the
  // server's review (vessels/missions.py item_problems says exactly what is wrong).
  function drawable(item) { return Math.abs(item.lat) <= 90 && Math.abs(item.lon) <= 180; }

  // The route as the server's review (admin ReviewView → vessels.missions.review) takes it.
  Planner.prototype.route = function (items) {
    var select = input("id_vessel"), current = document.querySelector("#planner-vessels li[data-current]");
    return {
      rows: items.map(function (i) { return { lat: i.lat, lon: i.lon, hold_s: i.hold, radius_m: i.radius, speed_mps: i.speed }; }),
      end: this.end(), home: this.home(),
      vessel: select ? (select.value || null) : (current ? current.dataset.id : null),
    };
  };

  // Figures and checks come from the server, computed once (vessels/missions.py review) for
  // this list, the route table and a send: the map is drawn at once, the numbers follow.
  Planner.prototype.requestReview = function (items) {
    var self = this, seq = (this.reviewSeq = (this.reviewSeq || 0) + 1);
    var url = document.getElementById("planner-saved-mission").dataset.reviewUrl;
    var token = document.querySelector("input[name=csrfmiddlewaretoken]");
    this.list.dataset.state = "pending";
    fetch(url, {
      method: "POST", credentials: "same-origin",
      headers: { "Content-Type": "application/json", "X-CSRFToken": token ? token.value : "" },
      body: JSON.stringify(this.route(items)),
    }).then(function (r) { return r.ok ? r.json() : Promise.reject(new Error("HTTP " + r.status)); })
      .then(function (review) { if (seq === self.reviewSeq) { self.showReview(items, review); } })
      .catch(function (err) {
        if (seq !== self.reviewSeq) { return; }
        self.list.dataset.state = "failed";
        var total = document.getElementById("planner-total");
        if (total) { total.textContent = "Figures unavailable (" + err.message + ")."; }
      });
  };

  // Where the vessel starts waypoint 1 from: the mission's home, else the vessel's last fix.
  Planner.prototype.start = function () {
    var home = this.home(), vessel = this.vessel();
    if (home) { return { at: home, label: "home" }; }
    if (vessel && vessel.at) { return { at: vessel.at, label: vessel.name }; }
    return null;
  };

  Planner.prototype.render = function () {
    var self = this, items = this.items(), vessel = this.vessel(), end = this.end(), home = this.home();
    var good = items.filter(drawable), start = this.start();
    this.layer.clearLayers();
    if (start && good.length) {
      L.polyline([start.at, [good[0].lat, good[0].lon]],
        { color: "#1565c0", weight: 2, opacity: 0.8, dashArray: "3 7", interactive: false, className: "planner-start-leg" }).addTo(this.layer);
    }
    var path = good.map(function (i) { return [i.lat, i.lon]; });
    if (path.length > 1) { L.polyline(path, { color: "#1565c0", weight: 3, interactive: false }).addTo(this.layer); }
    var closing = null;
    if (good.length > 1 && end === "loop") { closing = [good[good.length - 1], good[0]]; }
    if (good.length && end === "return_home" && home) { closing = [good[good.length - 1], { lat: home[0], lon: home[1] }]; }
    if (closing) {
      L.polyline([[closing[0].lat, closing[0].lon], [closing[1].lat, closing[1].lon]],
        { color: "#1565c0", weight: 2, dashArray: "6 6", interactive: false }).addTo(this.layer);
    }
    if (home) {
      L.marker(home, { interactive: false, icon: L.divIcon({ className: "home-icon", html: "H", iconSize: [20, 20], iconAnchor: [10, 10] }) })
        .addTo(this.layer);
    }
    if (vessel && vessel.at) {
      L.circleMarker(vessel.at, { radius: 5, color: "#555", fillOpacity: 0.6, interactive: false })
        .bindTooltip(el("span", { text: vessel.name + " (last fix)" })).addTo(this.layer);
    }
    this.problemLayer = L.layerGroup().addTo(this.layer);
    good.forEach(function (item, i) {
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
    this.renderList(items);
    this.rows().forEach(function (row) { row.classList.toggle("planner-selected", row === self.selected); });
    this.requestReview(items);
  };

  Planner.prototype.select = function (row) {
    this.selected = row;
    this.render();
    if (row) { row.scrollIntoView({ block: "nearest" }); }
  };

  // The list at once (positions, buttons); legs, times, problems and totals once reviewed.
  Planner.prototype.renderList = function (items) {
    var self = this, box = this.list, number = 0, start = this.start();
    // The hold and speed inputs survive the redraw (the same elements, moved into the new
    // rows), the one being typed in with its focus and caret.
    this.cellInputs = {};
    var kept = this.cellInputs;
    box.querySelectorAll("input[data-for]").forEach(function (i) { kept[i.dataset.for] = i; });
    var typing = box.contains(document.activeElement) && document.activeElement.dataset.for ? document.activeElement : null;
    var caret = typing && [typing.selectionStart, typing.selectionEnd];
    box.innerHTML = "";
    var head = el("tr", {}, ["#", "position", "hold (s)", "speed (m/s)", "leg", "time", ""].map(function (h) { return el("th", { text: h }); }));
    var table = el("table", { class: "planner-items" }, [head]);
    items.forEach(function (item, i) {
      var buttons = el("td", { class: "planner-buttons" });
      if (self.editable) {
        buttons.appendChild(el("button", { type: "button", title: "earlier", text: "↑", class: "planner-up", onclick: function () { self.shift(item, -1); } }));
        buttons.appendChild(el("button", { type: "button", title: "later", text: "↓", class: "planner-down", onclick: function () { self.shift(item, 1); } }));
        buttons.appendChild(el("button", { type: "button", title: "delete", text: "✕", class: "planner-delete", onclick: function () { self.remove(item); } }));
      }
      var label = drawable(item) ? String(++number) : "!";
      var first = number === 1 && drawable(item), leg = "";
      if (first) {
        leg = start ? "from " + start.label + " " + S.fmtDistance(S.geo.distance(start.at[0], start.at[1], item.lat, item.lon)) : "start";
      }
      var tr = el("tr", { class: item.row && item.row === self.selected ? "selected" : "", "data-index": String(i + 1) }, [
        el("td", { text: label }),
        el("td", { class: "planner-position" }, [S.positionEl(item.lat, item.lon)]),
        el("td", { class: "planner-hold" }, [self.cellInput(item, "hold_s", item.hold ? String(item.hold) : "", label)]),
        el("td", { class: "planner-speed" }, [self.cellInput(item, "speed_mps", item.speed === null ? "" : S.fmtSpeed(item.speed), label)]),
        el("td", { class: "planner-leg" + (first ? " planner-first-leg" : ""), text: leg }),
        el("td", { class: "planner-time" }),
        buttons,
      ]);
      tr.addEventListener("click", function (e) { if (["BUTTON", "INPUT"].indexOf(e.target.tagName) < 0) { self.select(item.row); } });
      table.appendChild(tr);
    });
    if (!items.length) {
      table.appendChild(el("tr", {}, [el("td", { colspan: "7", class: "muted", text: self.editable ? "No waypoints yet: click the map." : "No waypoints." })]));
    }
    box.appendChild(table);
    if (typing && box.contains(typing)) {
      typing.focus();
      if (caret[0] !== null) { typing.setSelectionRange(caret[0], caret[1]); }
    }
    box.appendChild(el("div", { class: "planner-totals" }, [
      el("p", { id: "planner-total", text: "…" }),
      el("ul", { id: "planner-problems", class: "errorlist" }),
      el("p", { id: "planner-end", class: "muted" }),
    ]));
  };

  // A waypoint's hold or speed, edited in its row: typed through to the inline row's field
  // (the form that is saved), whose input event redraws the map and asks for the figures.
  // Read-only (no form), the value as text.
  Planner.prototype.cellInput = function (item, name, text, label) {
    var target = item.row && field(item.row, name);
    if (!this.editable || !target) { return el("span", { text: text }); }
    var hold = name === "hold_s", old = this.cellInputs[target.name];
    if (old) {
      if (old !== document.activeElement) { old.value = shown(target.value, hold); }
      return old;
    }
    var box = el("input", {
      type: "text", inputmode: hold ? "numeric" : "decimal", class: "planner-" + (hold ? "hold" : "speed") + "-input",
      "data-for": target.name, value: shown(target.value, hold), autocomplete: "off",
      placeholder: hold ? "0" : "cruise", "aria-label": (hold ? "hold, seconds, " : "speed, m/s, ") + "waypoint " + label,
      title: hold ? "Seconds to hold at this waypoint" : "Speed from this waypoint on, m/s (empty: the vessel's cruise speed)",
    });
    // An emptied hold is no hold (the form's field needs a number); an emptied speed is the
    // cruise speed. A typo ("4o", "fast") is marked in the row at once, not read as 4 or as
    // the cruise speed: the form refuses it on save, but the figures meanwhile would lie.
    box.addEventListener("input", function () {
      var text = box.value.trim();
      target.value = text || (hold ? "0" : "");
      var bad = text !== "" && !(isFinite(Number(text)) && Number(text) >= 0);
      box.setCustomValidity(bad ? "not a number of " + (hold ? "seconds" : "m/s") : "");
      box.title = bad ? "“" + text + "” is not a number of " + (hold ? "seconds" : "m/s") + ": this row's figures ignore it, and Save refuses it" : box.dataset.help;
      box.classList.toggle("planner-input-invalid", bad);
    });
    box.dataset.help = box.title;
    return box;
  };

  // A hold of 0 shows as the empty box (its placeholder says 0), whatever the form wrote.
  function shown(value, hold) { return hold && parseFloat(value) === 0 ? "" : value; }

  Planner.prototype.showReview = function (items, review) {
    var self = this, end = this.end(), home = this.home(), vessel = this.vessel();
    var good = items.filter(drawable), trs = this.list.querySelectorAll("tr[data-index]");
    this.review = review;
    items.forEach(function (item, i) {
      var tr = trs[i], problems = review.rows[i] || [];
      tr.classList.toggle("planner-row-problem", problems.length > 0);
      tr.querySelector(".planner-hold").title = review.holds[i] || "";
      if (problems.length) {
        tr.querySelector(".planner-leg").textContent = problems.join("; ");
        tr.querySelector(".planner-leg").className = "planner-leg planner-error";
      }
    });
    review.legs.forEach(function (leg) {
      var a = good[leg.from - 1], b = leg.to === "home" ? { lat: home[0], lon: home[1] } : good[leg.to - 1];
      if (leg.problem) {
        L.polyline([[a.lat, a.lon], [b.lat, b.lon]], { color: "#c62828", weight: 4, dashArray: "8 6", interactive: false, className: "planner-bad-leg" })
          .addTo(self.problemLayer);
      }
      if (typeof leg.to !== "number" || leg.to !== leg.from + 1) { return; }
      var tr = trs[items.indexOf(b)];
      tr.querySelector(".planner-leg").textContent = leg.distance + (leg.problem ? " ⚠" : "");
      tr.querySelector(".planner-leg").title = leg.problem || "";
      tr.querySelector(".planner-time").textContent = leg.time;
      tr.classList.toggle("planner-leg-problem", !!leg.problem);
    });
    var closing = review.legs.filter(function (leg) { return leg.to === "home" || (good.length > 1 && leg.to === 1); })[0];
    var endText = { stop: "Then it stops at the last waypoint.", loop: "Then it loops back to waypoint 1", return_home: "Then it returns home" }[end] || "";
    if (closing) { endText += " (" + closing.distance + ", " + closing.time + ")."; }
    else if (end !== "stop") { endText += end === "return_home" ? " (home position not set: the autopilot's own home)." : "."; }
    var cruise = (vessel && vessel.cruise) || DEFAULT_CRUISE_SPEED_MPS;
    document.getElementById("planner-total").textContent = review.total;
    document.getElementById("planner-end").textContent = "Times at a cruise speed of " + S.fmtSpeed(cruise) + " unless an item sets its own. " + endText;
    var list = document.getElementById("planner-problems");
    review.problems.forEach(function (p) { list.appendChild(el("li", { text: p })); });
    this.list.dataset.state = "ready";
  };

  Planner.prototype.fit = function () {
    var items = this.items(), vessel = this.vessel(), home = this.home();
    var points = items.map(function (i) { return [i.lat, i.lon]; });
    if (home) { points.push(home); }
    if (points.length > 1) { this.map.fitBounds(L.latLngBounds(points).pad(0.2), { maxZoom: 16 }); }
    else if (points.length === 1) { this.map.setView(points[0], 15); }
    else if (vessel && vessel.at) { this.map.setView(vessel.at, 14); }
  };

  // --- sending ------------------------------------------------------------------------

  // The route on screen, as a send's "confirmed" (vessels/missions.py mismatch compares it).
  Planner.prototype.shown = function () {
    return {
      end: this.end(),
      items: this.items().map(function (i) {
        return { lat: i.lat, lon: i.lon, hold_s: i.hold, radius_m: i.radius, speed_mps: i.speed };
      }),
    };
  };

  // Why the form is not the saved mission, or "" when it is: Send sends the saved one.
  Planner.prototype.unsaved = function () {
    var saved = document.getElementById("planner-saved-mission").dataset;
    var was = this.savedItems(), now = this.items();
    function same(a, b) { return (a || 0) === (b || 0); }
    function e7(v) { return Math.round(v * 1e7); }
    if (was.length !== now.length) { return now.length + " waypoints on screen, " + was.length + " saved"; }
    for (var n = 0; n < now.length; n++) {
      var a = was[n], b = now[n];
      if (e7(a.lat) !== e7(b.lat) || e7(a.lon) !== e7(b.lon) || !same(a.hold, b.hold) ||
          !same(a.radius, b.radius) || !same(a.speed, b.speed)) {
        return "waypoint " + (n + 1) + " was changed";
      }
    }
    if (this.end() !== (saved.end || "stop")) { return "the end was changed"; }
    var home = this.home(), savedHome = saved.homeLat === "" ? null : [parseFloat(saved.homeLat), parseFloat(saved.homeLon)];
    if (JSON.stringify(home) !== JSON.stringify(savedHome)) { return "the home position was changed"; }
    var select = input("id_vessel"), current = document.querySelector("#planner-vessels li[data-current]");
    if (select && current && select.value !== current.dataset.id) { return "the vessel was changed"; }
    return "";
  };

  // Send refuses while the form has unsaved changes, asks the operator to confirm the
  // summary, and posts the route on screen for the server to compare with the saved one.
  Planner.prototype.hookSend = function () {
    var self = this, form = document.querySelector("form.send-mission");
    if (!form) { return; }
    form.addEventListener("submit", function (e) {
      var why = self.unsaved();
      if (why) {
        e.preventDefault();
        window.alert("Not sent: " + why + ". Save the mission first (Save and continue editing), then send.");
        return;
      }
      if (!window.confirm(form.dataset.confirm)) { e.preventDefault(); return; }
      form.querySelector("input[name=confirmed]").value = JSON.stringify(self.shown());
    });
  };

  window.ShoresideMissionPlanner = function (map) {
    S.baseMap(map);
    window.shoresidePlanner = new Planner(map);
    window.shoresidePlanner.hookSend();
  };
})();
