// Show only the parameter fields of the chosen command kind (admin command form).
(function () {
  "use strict";
  function update(select) {
    var kind = select.value;
    document.querySelectorAll("[data-kind]").forEach(function (input) {
      var row = input.closest(".form-row");
      if (row) { row.style.display = input.dataset.kind === kind ? "" : "none"; }
    });
  }
  document.addEventListener("DOMContentLoaded", function () {
    var select = document.querySelector("[data-command-kind]");
    if (!select) { return; }
    select.addEventListener("change", function () { update(select); });
    update(select);
  });
})();
