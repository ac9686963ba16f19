// `fabhal watch`: takes each new result from the server (server-sent events)
// and shows it in place: the scene (the camera stays), the status, and the
// program's errors over the last good scene, each linked to its line.
"use strict";
(function () {
  const live = document.getElementById("live");
  const source = document.getElementById("source");
  const events = new EventSource("/events");
  events.addEventListener("result", (event) => show(JSON.parse(event.data)));
  events.addEventListener("error", () => { live.querySelector(".connection").textContent = "reconnecting to fabhal watch ..."; });
  events.addEventListener("open", () => { live.querySelector(".connection").textContent = ""; });

  function show(result) {
    if (result.scene) window.fabhalViewer.load(result.scene);
    document.body.dataset.generation = String(result.generation);
    document.body.dataset.liveStatus = result.status;
    live.querySelector(".summary").textContent = result.summary +
      (result.scene ? "" : " (showing the last result that solved)");
    live.querySelector(".summary").className = `summary status ${result.status}`;
    const list = live.querySelector(".problems");
    list.replaceChildren();
    for (const problem of result.problems) {
      const item = document.createElement("li");
      const where = problem.file ? `${problem.file}:${problem.line}:${problem.column}` : "";
      const link = document.createElement(problem.file ? "a" : "span");
      link.textContent = where ? `${where}: ` : "";
      if (problem.file) {
        link.href = `#${where}`;
        link.addEventListener("click", (e) => { e.preventDefault(); showSource(result.sources[problem.file], problem); });
      }
      item.appendChild(link);
      item.appendChild(document.createTextNode(`${problem.severity}[${problem.code}]: ${problem.message}`));
      if (problem.help) {
        const help = document.createElement("div");
        help.className = "dofs";
        help.textContent = `help: ${problem.help}`;
        item.appendChild(help);
      }
      item.className = problem.severity === "error" ? "falls_apart" : "";
      list.appendChild(item);
    }
    const first = result.problems.find((p) => p.severity === "error" && p.file);
    if (first) showSource(result.sources[first.file], first);
    else source.hidden = true;
  }

  function showSource(text, problem) {
    if (text === undefined) return;
    source.replaceChildren();
    const title = document.createElement("div");
    title.className = "dofs";
    title.textContent = problem.file;
    source.appendChild(title);
    text.split("\n").forEach((line, index) => {
      const row = document.createElement("div");
      row.textContent = `${String(index + 1).padStart(4)} | ${line}`;
      if (index + 1 === problem.line) { row.className = "marked"; row.id = "marked-line"; }
      source.appendChild(row);
    });
    source.hidden = false;
    const marked = document.getElementById("marked-line");
    if (marked) marked.scrollIntoView({ block: "center" });
  }
})();
