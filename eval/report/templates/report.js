// Sortable tables: a click (or Enter) on a column header sorts the rows by that column, numbers by value (a cell's
// data-sort holds the unrounded number), text in natural order; empty cells last; again: the other way round.
(function () {
  "use strict";
  var collator = new Intl.Collator(undefined, { numeric: true, sensitivity: "base" });
  function key(row, column) {
    var cell = row.cells[column];
    var text = cell ? cell.textContent.trim() : "";
    var raw = cell && cell.hasAttribute("data-sort") ? cell.getAttribute("data-sort") : text;
    var number = Number(raw);
    if (raw !== "" && !isNaN(number)) return { rank: 0, number: number, text: text };
    return { rank: raw === "" || raw === "n/a" ? 2 : 1, number: 0, text: raw };
  }
  function compare(a, b) {
    if (a.rank !== b.rank) return a.rank - b.rank;
    if (a.rank === 0) return a.number - b.number;
    return collator.compare(a.text, b.text);
  }
  function sort(table, header, column) {
    var body = table.tBodies[0];
    var direction = header.getAttribute("aria-sort") === "ascending" ? -1 : 1;
    Array.prototype.forEach.call(table.tHead.rows[0].cells, function (th) { th.removeAttribute("aria-sort"); });
    header.setAttribute("aria-sort", direction === 1 ? "ascending" : "descending");
    var rows = Array.prototype.map.call(body.rows, function (row) { return { row: row, key: key(row, column) }; });
    rows.sort(function (a, b) {
      var order = compare(a.key, b.key);
      return a.key.rank === b.key.rank ? order * direction : order;
    });
    rows.forEach(function (item) { body.appendChild(item.row); });
  }
  document.querySelectorAll("table.sortable").forEach(function (table) {
    if (!table.tHead || !table.tBodies.length) return;
    Array.prototype.forEach.call(table.tHead.rows[0].cells, function (header, column) {
      header.tabIndex = 0;
      header.title = (header.title ? header.title + ": " : "") + "click to sort";
      header.addEventListener("click", function () { sort(table, header, column); });
      header.addEventListener("keydown", function (event) {
        if (event.key === "Enter" || event.key === " ") { event.preventDefault(); sort(table, header, column); }
      });
    });
  });
})();
