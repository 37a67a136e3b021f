// The page's statements go through the session like the REPL's; the log refreshes on each event.
const token = new URLSearchParams(location.search).get("token");
const api = (p) => p + "?token=" + encodeURIComponent(token);
async function refresh() {
  const s = await (await fetch(api("/api/state"))).json();
  document.getElementById("status").textContent = s.status;
  document.getElementById("log").textContent =
    s.log.map((l) => `[${l.from}] ${l.statement}\n${l.reply}`).join("\n");
}
document.getElementById("f").onsubmit = async (e) => {
  e.preventDefault();
  await fetch(api("/api/statement"), { method: "POST", body: document.getElementById("stmt").value });
  refresh();
};
document.getElementById("stop").onclick = () => fetch(api("/api/stop"), { method: "POST" });
new EventSource(api("/api/events")).addEventListener("statement", refresh);
refresh();
