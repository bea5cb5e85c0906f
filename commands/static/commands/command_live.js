// A command's admin page follows the command live (issue 18 §3): while it is unfinished, ask
// its state (CommandAdmin.state_view) every poll_s seconds; when the status or the number of
// transitions changed, fetch the page again and put its form (the read-only fields and the
// transition log) in place of this one, without a reload. Stops once the command is finished.
(function () {
  "use strict";

  function start() {
    var live = document.getElementById("command-live");
    if (!live || !live.dataset.unfinished) { return; }
    var pollMs = Math.max(1, parseFloat(live.dataset.pollS) || 5) * 1000;
    var timer = null;

    function say(text, problem) {
      live.textContent = text;
      live.classList.toggle("errornote", !!problem);
    }

    function redraw() {
      return fetch(location.href, { credentials: "same-origin", headers: { Accept: "text/html" } })
        .then(function (r) { if (!r.ok) { throw new Error("HTTP " + r.status); } return r.text(); })
        .then(function (html) {
          var page = new DOMParser().parseFromString(html, "text/html");
          var form = page.querySelector("#content-main form"), here = document.querySelector("#content-main form");
          if (!form || !here) { throw new Error("the page has no command form"); }
          here.replaceWith(document.importNode(form, true));
          // The title and breadcrumbs name the status too.
          [".breadcrumbs", "#content > h2"].forEach(function (css) {
            var now = page.querySelector(css), old = document.querySelector(css);
            if (now && old) { old.replaceWith(document.importNode(now, true)); }
          });
          live = document.getElementById("command-live");
        });
    }

    function check() {
      fetch(live.dataset.stateUrl, { credentials: "same-origin", headers: { Accept: "application/json" } })
        .then(function (r) { if (!r.ok) { throw new Error("HTTP " + r.status); } return r.json(); })
        .then(function (state) {
          var moved = state.status !== live.dataset.status || String(state.events) !== live.dataset.events;
          return (moved ? redraw() : Promise.resolve()).then(function () { return state; });
        })
        .then(function (state) {
          if (state.unfinished) { timer = setTimeout(check, pollMs); }
        })
        .catch(function (err) {
          say("Live updates interrupted (" + err.message + "); trying again.", true);
          timer = setTimeout(check, pollMs);
        });
    }

    timer = setTimeout(check, pollMs);
  }

  if (document.readyState === "loading") { document.addEventListener("DOMContentLoaded", start); }
  else { start(); }
})();
