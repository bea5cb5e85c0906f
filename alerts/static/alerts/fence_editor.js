// The fence's map on its admin page: draw a polygon, a rectangle or a circle (Leaflet.draw),
// edit or delete it; the form's geometry field (GeoJSON, [longitude, latitude]) and radius
// follow the drawing, and GeoJSON pasted into the field is drawn. The server checks the
// fence (vessels.fences.clean); this only keeps the form and the map in step.
(function () {
  "use strict";
  var S = window.Shoreside;
  var STYLE = { inclusion: "#2e7d32", exclusion: "#c62828" };
  var DECIMALS = 7; // ~1 cm, as the server keeps them

  function round(x) { var f = Math.pow(10, DECIMALS); return Math.round(x * f) / f; }

  function FenceEditor(map) {
    this.map = map;
    this.geometryField = document.querySelector("textarea[name=geometry]");
    this.radiusField = document.querySelector("input[name=radius_m]");
    this.inclusionField = document.querySelector("input[name=inclusion]");
    this.drawn = new L.FeatureGroup().addTo(map);
    var self = this;
    map.addControl(new L.Control.Draw({
      position: "topleft",
      draw: {
        polygon: { allowIntersection: false, showArea: false, shapeOptions: this.style() },
        rectangle: { shapeOptions: this.style() },
        circle: { shapeOptions: this.style() },
        polyline: false, marker: false, circlemarker: false,
      },
      edit: { featureGroup: this.drawn },
    }));
    map.on(L.Draw.Event.CREATED, function (e) {
      self.drawn.clearLayers();
      self.drawn.addLayer(e.layer);
      self.toForm();
    });
    map.on(L.Draw.Event.EDITED, function () { self.toForm(); });
    map.on(L.Draw.Event.DELETED, function () { self.toForm(); });
    if (this.geometryField) {
      this.geometryField.addEventListener("change", function () { self.fromForm(true); });
    }
    if (this.radiusField) { this.radiusField.addEventListener("change", function () { self.fromForm(false); }); }
    if (this.inclusionField) { this.inclusionField.addEventListener("change", function () { self.restyle(); }); }
    this.fromForm(true);
  }

  FenceEditor.prototype.style = function () {
    var inclusion = !this.inclusionField || this.inclusionField.checked;
    var colour = inclusion ? STYLE.inclusion : STYLE.exclusion;
    return { color: colour, weight: 3, fillOpacity: 0.15, dashArray: inclusion ? null : "8 6" };
  };

  FenceEditor.prototype.restyle = function () {
    var style = this.style();
    this.drawn.eachLayer(function (layer) { layer.setStyle(style); });
  };

  // The drawing into the form: a circle is its centre and radius; anything else a polygon.
  FenceEditor.prototype.toForm = function () {
    var layers = this.drawn.getLayers(), geometry = null, radius = "";
    if (layers.length) {
      var layer = layers[layers.length - 1];
      if (layer instanceof L.Circle) {
        var c = layer.getLatLng();
        geometry = { type: "Point", coordinates: [round(c.lng), round(c.lat)] };
        radius = String(Math.round(layer.getRadius() * 10) / 10);
      } else {
        var ring = layer.getLatLngs()[0].map(function (p) { return [round(p.lng), round(p.lat)]; });
        ring.push(ring[0]); // GeoJSON closes the ring (RFC 7946 §3.1.6)
        geometry = { type: "Polygon", coordinates: [ring] };
      }
    }
    if (this.geometryField) { this.geometryField.value = geometry ? JSON.stringify(geometry) : ""; }
    if (this.radiusField) { this.radiusField.value = radius; }
    this.restyle();
  };

  // The form into the drawing (the saved fence, or GeoJSON pasted into the field).
  FenceEditor.prototype.fromForm = function (fit) {
    var text = this.geometryField ? this.geometryField.value.trim() : "", geometry = null;
    try { geometry = text ? JSON.parse(text) : null; } catch (e) { return; }
    this.drawn.clearLayers();
    if (!geometry || !geometry.coordinates) { return; }
    var layer = null;
    if (geometry.type === "Polygon" && geometry.coordinates[0]) {
      var ring = geometry.coordinates[0].map(function (p) { return [p[1], p[0]]; });
      if (ring.length > 1) { ring.pop(); }
      layer = L.polygon(ring, this.style());
    } else if (geometry.type === "Point") {
      var radius = Number(this.radiusField && this.radiusField.value) || 0;
      layer = L.circle([geometry.coordinates[1], geometry.coordinates[0]], L.extend({ radius: radius }, this.style()));
    }
    if (!layer) { return; }
    this.drawn.addLayer(layer);
    if (fit) { this.map.fitBounds(layer.getBounds().pad(0.3), { maxZoom: 16 }); }
  };

  window.ShoresideFenceEditor = function (map) {
    S.baseMap(map);
    window.shoresideFenceEditor = new FenceEditor(map);
  };
})();
