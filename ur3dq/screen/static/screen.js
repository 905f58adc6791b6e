// The cell screen's page: one WebSocket to `ur3dq serve`, a heartbeat every 50 ms, the live state drawn as it
// comes, the buttons sent as commands. Numbers arrive already written in the page's units (the server's units
// layer); what a person types goes to the server as typed, and the server reads it in those units.
// The 3D view (three.js, half a megabyte to parse) loads after the socket is open and the drawing worker has
// started, so the readouts and the worker's own three.js come in while this page parses it.

const $ = (selector) => document.querySelector(selector);
const BEAT_MS = 50;
const JOINTS = ["J1", "J2", "J3", "J4", "J5", "J6"];
const TCP_AXES = ["X", "Y", "Z", "RX", "RY", "RZ"];
const IO_GROUPS = [["standard", "DO", "DI", 8], ["configurable", "CO", "CI", 8], ["tool", "TO", "TI", 2]];

const screen = {            // what tests and the page itself read: timing and counts, no behaviour
  openedAt: Date.now(), firstStateAt: null, firstArmDrawnAt: null, updates: 0, updateTimes: [],
};
window.ur3dqScreen = screen;

let socket = null, state = null, program = { steps: [] }, check = null, hello = null, selected = null, scene = null;
let nextId = 1, heldJog = null, view = null, pendingRecord = false, buttonsKey = "";
const token = new URLSearchParams(location.search).get("token");

// ---------------------------------------------------------------------------------------------------- socket
function connect() {
  const url = new URL("/ws", location.href);
  url.protocol = location.protocol === "https:" ? "wss:" : "ws:";
  if (token) url.searchParams.set("token", token);
  socket = new WebSocket(url);
  socket.onopen = () => {   // the units this browser chose last; else the server's (`ur3dq serve --deg --mm`)
    const units = JSON.parse(localStorage.getItem("ur3dq-units") || "null");
    if (units) send({ type: "units", ...units });
  };
  socket.onmessage = (event) => receive(JSON.parse(event.data));
  socket.onclose = () => {
    state = null;
    buttonsKey = "";
    $("#robot-line").textContent = "disconnected from ur3dq serve: reconnecting…";
    releaseJog();
    refreshButtons();
    setTimeout(connect, 1000);
  };
}

function send(message) {
  if (socket && socket.readyState === WebSocket.OPEN) socket.send(JSON.stringify(message));
}

function command(cmd, args = {}) {
  send({ type: "cmd", cmd, args, id: nextId++ });
}

setInterval(() => send({ type: "beat" }), BEAT_MS);

function receive(message) {
  switch (message.type) {
    case "hello": hello = message; applyHello(); break;
    case "scene": scene = message; if (view) { view.setArm(message.arm); view.setCell(message.cell); } break;
    case "program": program = message; renderProgram(); break;
    case "check": check = message; renderCheck(); break;
    case "state": applyState(message); break;
    case "confirm": confirmQuestion(message); break;
    case "withdrawn": if ($("#ask").open && $("#ask").dataset.qid === message.qid) $("#ask").close(); break;
    case "reply": showReply(message); break;
  }
}

// ---------------------------------------------------------------------------------------------------- state
function applyHello() {
  $("#unit-angle").value = hello.units.angle;
  $("#unit-length").value = hello.units.length;
  const steps = $("#jog-step");
  const chosen = steps.value;
  steps.replaceChildren(...hello.joint_steps.map((label, index) => {
    const option = new Option(`${label} / ${hello.linear_steps[index]}`, String(index));
    return option;
  }));
  steps.value = chosen || "0";
  showJogSpeed();
}

function applyState(message) {
  const first = state === null;
  state = message;
  screen.updates += 1;
  const now = Date.now();
  screen.updateTimes.push([message.read_at * 1000, now]);   // when the server read it, when the page got it
  if (screen.updateTimes.length > 600) screen.updateTimes.splice(0, 300);
  if (first && screen.firstStateAt === null) screen.firstStateAt = now;
  message.joints_text.forEach((text, index) => setText(document.querySelector(`[data-joint="${index}"]`), text));
  message.tcp_text.forEach((text, index) => setText(document.querySelector(`[data-tcp="${index}"]`), text));
  setText($("#robot-mode"), message.robot_mode);
  setText($("#safety-mode"), message.safety_mode || "—");
  setText($("#program-state"), message.program);
  const doing = message.activity ? ` — ${message.activity}` : "";
  const live = message.stale ? `${message.stale}: state unknown`
    : `${message.robot_mode}, ${message.safety_mode}, program ${message.program}`;
  setText($("#robot-line"), message.connected ? `${hello ? hello.host : ""}: ${live}${doing}`
    : `no robot: ${message.message || "connecting…"}`);
  markStale(!!message.stale);
  const control = message.control;
  const line = $("#control-line");
  setText(line, control.you ? "You have control." : control.holder
    ? `Read-only: ${control.holder} has control.` : "Nobody has control: take it to move the arm.");
  line.classList.toggle("readonly", !control.you);
  if (document.activeElement !== $("#speed-slider")) {
    $("#speed-slider").value = Math.round(message.speed_slider * 100);
  }
  setText($("#speed-value"), message.connected ? `${Math.round(message.speed_slider * 100)} %` : "—");
  $("#freedrive").setAttribute("aria-pressed", String(message.freedrive));
  renderIO(message);
  markRunning(message.running_step);
  setText($("#run-progress"), message.activity === "run"
    ? `running${message.running_step ? " " + message.running_step : ""}${message.loop ? ", loop " + message.loop : ""}` : "");
  if (view && message.arm) view.placeArm(message.arm);
  const key = JSON.stringify([message.connected, message.ready, message.robot_mode, message.safety_mode,
    message.program, message.activity, message.freedrive, message.control]);
  if (key !== buttonsKey) { buttonsKey = key; refreshButtons(); }   // a moving arm changes none of them
}

// Readouts of stale data (the server says so, or no state came for STATE_SILENCE_MS) are greyed out.
const STATE_SILENCE_MS = 1000;
function markStale(stale) {
  document.body.classList.toggle("stale", stale);
}
setInterval(() => {
  const last = screen.updateTimes.length ? screen.updateTimes[screen.updateTimes.length - 1][1] : null;
  if (state && last !== null && Date.now() - last > STATE_SILENCE_MS) {
    markStale(true);
    setText($("#robot-line"), "no state from ur3dq serve for over a second: state unknown");
  }
}, 250);

function setText(element, text) {
  if (element && element.textContent !== text) element.textContent = text;
}

function markRunning(name) {
  const current = document.querySelector('#steps [aria-current="step"]');
  if (current && current.dataset.step === name) return;
  if (current) current.removeAttribute("aria-current");
  if (!name) return;
  const row = document.querySelector(`#steps [data-step="${CSS.escape(name)}"]`);
  if (row) {
    row.setAttribute("aria-current", "step");
    followInList(row);
  }
}

// Scrolls the step list alone to show `row` (scrollIntoView would scroll the panels too, and the page).
function followInList(row) {
  const list = $("#steps"), box = row.getBoundingClientRect(), shown = list.getBoundingClientRect();
  if (box.top < shown.top) list.scrollTop -= shown.top - box.top;
  else if (box.bottom > shown.bottom) list.scrollTop += box.bottom - shown.bottom;
}

// ---------------------------------------------------------------------------------------------------- buttons
function refreshButtons() {
  const s = state, you = !!(s && s.control.you), up = !!(s && s.connected && s.ready);
  const running = up && s.robot_mode === "RUNNING", idle = !(s && s.activity);
  const jogging = !!(s && s.activity && s.activity.startsWith("jog"));
  const step = selectedStep();
  const able = {
    "#take-control": !!s && !s.control.you,
    "#power-on": you && up && s.robot_mode === "POWER_OFF",
    "#power-off": you && up && s.robot_mode !== "POWER_OFF" && idle,
    "#brake-release": you && up && s.robot_mode === "IDLE",
    "#unlock": you && up && s.safety_mode === "PROTECTIVE_STOP",
    "#freedrive": you && running && (idle || (s.activity || "").startsWith("freedrive")),
    "#record": you && up,
    "#move-here": you && running && idle && !!step && step.waypoint && !program.store_error,
    "#check": !!s && program.steps.length > 0 && !program.store_error,
    "#run-button": you && running && idle && program.steps.length > 0 && s.program === "STOPPED" && !program.store_error,
    "#pause": up && s.program === "PLAYING" && s.activity === "run",   // every page may pause and stop
    "#resume": you && up && s.program === "PAUSED",
    "#stop": up && (!idle || s.program !== "STOPPED"),
    "#undo": you && !!program.can_undo, "#redo": you && !!program.can_redo,
    "#step-up": you && !!step, "#step-down": you && !!step, "#step-rename": you && !!step,
    "#step-delete": you && !!step, "#retouch": you && up && !!step && step.recorded,
    "#add-output": you, "#add-wait": you, "#add-message": you,
    "#speed-slider": you && up,
  };
  for (const [selector, enabled] of Object.entries(able)) $(selector).disabled = !enabled;
  const canJog = you && running && (idle || jogging) && !s.freedrive;
  for (const button of document.querySelectorAll(".jog button")) button.disabled = !canJog && !button.classList.contains("held");
  for (const button of document.querySelectorAll("#io button")) button.disabled = !(you && up);
  $("#undo").title = program.undo_text || "";
  $("#redo").title = program.redo_text || "";
  $("#motion-editor").hidden = !(step && step.waypoint);
}

function bind(selector, action) {
  $(selector).addEventListener("click", action);
}

bind("#take-control", () => send({ type: "take_control" }));
bind("#power-on", () => command("power_on"));
bind("#power-off", () => command("power_off"));
bind("#brake-release", () => command("brake_release"));
bind("#unlock", () => command("unlock"));
bind("#freedrive", () => command("freedrive", { on: !(state && state.freedrive) }));
bind("#move-here", () => command("move_here", { name: selected }));
bind("#check", () => command("check", { from: fromStep() }));
bind("#run-button", () => command("run", { from: fromStep(), loops: $("#loops").value }));
bind("#pause", () => command("pause"));
bind("#resume", () => command("resume"));
bind("#stop", () => command("stop"));
bind("#undo", () => command("undo"));
bind("#redo", () => command("redo"));
bind("#step-up", () => edit("move", { name: selected, offset: -1 }));
bind("#step-down", () => edit("move", { name: selected, offset: 1 }));
bind("#step-delete", () => edit("delete", { name: selected }));
bind("#retouch", () => command("retouch", { name: selected }));
bind("#record", () => {
  pendingRecord = true;
  command("default_name");
});
bind("#step-rename", () => ask(`Rename ${selected} to:`, [field("new", "new name", selected)], "OK",
  (values) => edit("rename", { name: selected, new: values.new })));
bind("#add-output", () => ask("Add a digital output step after the selected step:", [
  choice("group", "output", ["standard", "tool", "configurable"]), field("pin", "pin", "0"),
  choice("on", "value", ["on", "off"]), field("step_name", "name (optional)", "")], "OK",
(values) => edit("output", { ...values, on: values.on === "on", after: selected })));
bind("#add-wait", () => ask("Add a wait step after the selected step:", [
  field("seconds", "seconds (or e.g. 500ms)", "0.5"), field("step_name", "name (optional)", "")], "OK",
(values) => edit("wait", { ...values, after: selected })));
bind("#add-message", () => ask("Add a message step after the selected step:", [
  field("text", "text", ""), field("step_name", "name (optional)", "")], "OK",
(values) => edit("message", { ...values, after: selected })));
$("#motion-editor").addEventListener("submit", (event) => {
  event.preventDefault();
  editorFrom = { name: selected, values: editorValues() };   // applied: the step's answer may refill it
  edit("motion", { name: selected, move: $("#edit-move").value, speed: $("#edit-speed").value,
    blend: $("#edit-blend").value });
});
$("#speed-slider").addEventListener("change", (event) => command("speed", { fraction: Number(event.target.value) / 100 }));
$("#jog-speed").addEventListener("input", showJogSpeed);
for (const id of ["#unit-angle", "#unit-length"]) {
  $(id).addEventListener("change", () => {
    const units = { angle: $("#unit-angle").value, length: $("#unit-length").value };
    localStorage.setItem("ur3dq-units", JSON.stringify(units));
    send({ type: "units", ...units });
  });
}
function edit(kind, fields) {
  if (["output", "wait", "message"].includes(kind)) selectNewStep();
  command("edit", { kind, fields });
}

// The next program that holds exactly one new step gets it selected (a step added goes after the selected one,
// so adding several puts them in the order they were added).
let namesBefore = null;
function selectNewStep() {
  namesBefore = new Set(program.steps.map((step) => step.name));
}

// The step list from the keyboard (a listbox whose selection follows the focus): arrows, Home/End, Page Up/Down.
$("#steps").addEventListener("keydown", (event) => {
  const rows = [...document.querySelectorAll("#steps li")], at = rows.indexOf(document.activeElement);
  const to = { ArrowDown: at + 1, ArrowUp: at - 1, Home: 0, End: rows.length - 1, PageDown: at + 10,
    PageUp: at - 10 }[event.key];
  if (at < 0 || (to === undefined && event.key !== "Enter" && event.key !== " ")) return;
  event.preventDefault();
  const row = to === undefined ? rows[at] : rows[Math.max(0, Math.min(rows.length - 1, to))];
  select(row.dataset.step);
  row.focus();
});

function fromStep() {
  return $("#from-selected").checked && selected ? selected : null;
}

function showJogSpeed() {
  const percent = Number($("#jog-speed").value);
  $("#jog-speed-value").textContent = hello
    ? `${percent} % of ${hello.max_joint_speed} / ${hello.max_tcp_speed}` : `${percent} %`;
}

// ---------------------------------------------------------------------------------------------------- jog
function buildJog() {
  const rows = (axes, table, readout) => {
    $(table).querySelector("tbody").replaceChildren(...axes.map((axis, index) => {
      const row = document.createElement("tr");
      row.innerHTML = `<th scope="row">${axis}</th><td class="readout"><output ${readout}="${index}">—</output></td>` +
        `<td><button type="button" data-axis="${axis}" data-direction="-1">${axis}-</button> ` +
        `<button type="button" data-axis="${axis}" data-direction="1">${axis}+</button></td>`;
      return row;
    }));
  };
  rows(JOINTS, "#jog-joints", "data-joint");
  rows(TCP_AXES, "#jog-tcp", "data-tcp");
  for (const button of document.querySelectorAll(".jog button")) {
    button.addEventListener("pointerdown", (event) => {
      if (button.disabled) return;
      event.preventDefault();
      button.setPointerCapture(event.pointerId);
      holdJog(button);
    });
    for (const end of ["pointerup", "pointercancel", "lostpointercapture"]) button.addEventListener(end, releaseJog);
    button.addEventListener("keydown", (event) => {
      if ((event.key === " " || event.key === "Enter") && !event.repeat) { event.preventDefault(); holdJog(button); }
    });
    // A jog held by a key ends when that key comes up wherever the focus is, and when the focus leaves the button
    // (Tab, a click or tap elsewhere): the key-up would otherwise go to another element and the arm move on.
    button.addEventListener("focusout", () => { if (heldJog === button) releaseJog(); });
    button.addEventListener("contextmenu", (event) => event.preventDefault());
  }
}

function holdJog(button) {
  if (heldJog) releaseJog();
  heldJog = button;
  button.classList.add("held");
  command("jog", { axis: button.dataset.axis, direction: Number(button.dataset.direction),
    frame: $("#jog-frame").value, step: Number($("#jog-step").value),
    speed: Number($("#jog-speed").value) / 100 });
}

function releaseJog() {
  if (!heldJog) return;
  heldJog.classList.remove("held");
  heldJog = null;
  command("jog_stop");
}

window.addEventListener("blur", releaseJog);
window.addEventListener("keyup", (event) => { if (event.key === " " || event.key === "Enter") releaseJog(); }, true);
document.addEventListener("visibilitychange", () => { if (document.hidden) releaseJog(); });

// ---------------------------------------------------------------------------------------------------- I/O
function buildIO() {
  const cells = [];
  for (const [group, out, input, count] of IO_GROUPS) {
    const outputs = document.createElement("span");
    outputs.className = "group";
    outputs.textContent = `${group} out`;
    cells.push(outputs);
    for (let pin = 0; pin < 8; pin++) {
      if (pin >= count) { cells.push(document.createElement("span")); continue; }
      const button = document.createElement("button");
      button.type = "button";
      button.textContent = `${out} ${pin}`;
      button.dataset.io = `${group}:${pin}`;
      button.setAttribute("aria-pressed", "false");
      button.addEventListener("click", () => command("output", { group, pin,
        on: button.getAttribute("aria-pressed") !== "true" }));
      cells.push(button);
    }
    const inputs = document.createElement("span");
    inputs.className = "group";
    inputs.textContent = `${group} in`;
    cells.push(inputs);
    for (let pin = 0; pin < 8; pin++) {
      const lamp = document.createElement("span");
      if (pin < count) {
        lamp.className = "lamp";
        lamp.textContent = `${input} ${pin}`;
        lamp.dataset.input = `${group}:${pin}`;
        lamp.setAttribute("role", "status");
      }
      cells.push(lamp);
    }
  }
  $("#io").replaceChildren(...cells);
}

function renderIO(message) {
  for (const button of document.querySelectorAll("#io button")) {
    const [group, pin] = button.dataset.io.split(":");
    const on = !!(message.outputs && message.outputs[group][Number(pin)]);
    if (button.getAttribute("aria-pressed") !== String(on)) button.setAttribute("aria-pressed", String(on));
  }
  for (const lamp of document.querySelectorAll("#io .lamp")) {
    const [group, pin] = lamp.dataset.input.split(":");
    lamp.classList.toggle("on", !!(message.inputs && message.inputs[group][Number(pin)]));
  }
}

// ---------------------------------------------------------------------------------------------------- program
function selectedStep() {
  return program.steps.find((step) => step.name === selected) || null;
}

function renderProgram() {
  $("#program-source").textContent = program.source || "";
  $("#store-error").textContent = program.store_error || "";
  $("#store-error").hidden = !program.store_error;
  if (namesBefore) {
    const added = program.steps.filter((step) => !namesBefore.has(step.name));
    if (added.length === 1) { selected = added[0].name; namesBefore = null; }
  }
  if (selected && !program.steps.some((step) => step.name === selected)) selected = null;
  const running = state && state.running_step;
  const focused = $("#steps").contains(document.activeElement);
  $("#steps").replaceChildren(...program.steps.map((step, index) => {
    const row = document.createElement("li");
    row.dataset.step = step.name;
    row.setAttribute("role", "option");
    row.tabIndex = step.name === selected || (!selected && index === 0) ? 0 : -1;   // one Tab stop: the selected
    row.setAttribute("aria-selected", String(step.name === selected));
    if (step.name === selected) row.classList.add("selected");
    if (step.name === running) row.setAttribute("aria-current", "step");
    const verdict = check && check.verdicts ? check.verdicts[step.name] : null;
    if (verdict) row.classList.add(verdict);
    const cells = [["index", String(index + 1)], ["name", step.name], ["kind", step.kind],
      ["move", step.move || ""], ["speed", step.speed], ["verdict", ""]];
    for (const [name, text] of cells) {
      const cell = document.createElement("span");
      cell.className = name;
      cell.textContent = text;
      row.append(cell);
    }
    const details = document.createElement("span");
    details.className = "details";
    const blend = step.blend && step.blend !== "default" ? `blend ${step.blend}` : "";
    details.textContent = [blend, step.details].filter(Boolean).join(" · ");
    row.append(details);
    row.addEventListener("click", () => select(step.name));
    return row;
  }));
  if (focused) { const row = $('#steps [tabindex="0"]'); if (row) row.focus({ preventScroll: true }); }
  if (view) view.setFrames(program.frames);
  fillMotionEditor();
  refreshButtons();
}

function select(name) {
  const chosen = name !== selected;
  selected = name;
  for (const row of document.querySelectorAll("#steps li")) {
    const on = row.dataset.step === selected;
    row.classList.toggle("selected", on);
    row.setAttribute("aria-selected", String(on));
    row.tabIndex = on ? 0 : -1;
  }
  fillMotionEditor(chosen);
  refreshButtons();
}

// What the motion editor was last filled with, {name, values}: the operator has typed while the fields differ.
let editorFrom = null;
function editorValues() { return [$("#edit-move").value, $("#edit-speed").value, $("#edit-blend").value]; }

// Fills the motion editor from the selected step, except over what the operator typed and has not applied while
// the list merely changed around that step (`chosen`: another step was selected, which always refills it).
function fillMotionEditor(chosen = false) {
  const step = selectedStep();
  const typed = !chosen && editorFrom && editorValues().join("\n") !== editorFrom.values.join("\n");
  if (!step || !step.waypoint) {
    if (typed) tell(`'${editorFrom.name}' is gone: its motion edit was not applied.`);
    editorFrom = null;
    return;
  }
  const values = [step.move, step.speed === "default" ? "" : step.speed, step.blend === "default" ? "" : step.blend];
  if (typed && editorFrom.name === step.name) {
    if (values.join("\n") === editorFrom.values.join("\n")) return;
    tell(`'${step.name}' was changed elsewhere: the motion editor shows it now; your edit was not applied.`);
  }
  [$("#edit-move").value, $("#edit-speed").value, $("#edit-blend").value] = values;
  editorFrom = { name: step.name, values };
}

function tell(text) {
  const notice = $("#notice");
  notice.textContent = text;
  notice.className = "";
  notice.setAttribute("role", "status");
}

function renderCheck() {
  const summary = $("#check-summary");
  const problems = (check && check.problems) || [];
  summary.textContent = !check ? "" : check.ok ? `Check passed: ${check.summary}` +
    (check.smallest ? ` (${check.smallest})` : "") : `Check failed: ${problems.length} problem` +
    `${problems.length === 1 ? "" : "s"}${check.smallest ? ` (${check.smallest})` : ""}`;
  summary.className = check ? (check.ok ? "ok" : "fail") : "";
  $("#problems").replaceChildren(...problems.map((problem) => {
    const item = document.createElement("li");
    item.textContent = problem.line;
    return item;
  }));
  for (const row of document.querySelectorAll("#steps li")) {
    row.classList.remove("ok", "fail");
    const verdict = check && check.verdicts ? check.verdicts[row.dataset.step] : null;
    if (verdict) row.classList.add(verdict);
  }
  if (view) view.setCheck(check);
}

// ---------------------------------------------------------------------------------------------------- dialogs
function field(name, label, value) { return { name, label, value }; }
function choice(name, label, options) { return { name, label, options }; }

// A modal question: `fields` to fill in, then onOk(values) on OK (or onCancel() on Cancel / No).
function ask(text, fields, okLabel, onOk, cancelLabel = "Cancel", onCancel = null) {
  const dialog = $("#ask");
  delete dialog.dataset.qid;
  $("#ask-text").textContent = text;
  $("#ask-fields").replaceChildren(...fields.map((spec) => {
    const label = document.createElement("label");
    label.textContent = `${spec.label} `;
    const input = spec.options ? document.createElement("select") : document.createElement("input");
    if (spec.options) input.append(...spec.options.map((option) => new Option(option, option)));
    else input.value = spec.value;
    input.name = spec.name;
    label.append(input);
    return label;
  }));
  const buttons = [[okLabel, true], [cancelLabel, false]].map(([label, yes]) => {
    const button = document.createElement("button");
    button.type = "button";
    button.textContent = label;
    button.addEventListener("click", () => {
      const values = Object.fromEntries(fields.map((spec) => [spec.name, dialog.querySelector(`[name="${spec.name}"]`).value]));
      dialog.close();
      if (yes) onOk(values);
      else if (onCancel) onCancel();
    });
    return button;
  });
  $("#ask-buttons").replaceChildren(...buttons);
  // Enter in a text field is OK (the form's own submission would just close the dialog); a question without
  // fields has its focus on No, so Enter there is No.
  for (const input of dialog.querySelectorAll("#ask-fields input")) {
    input.addEventListener("keydown", (event) => {
      if (event.key === "Enter" && !event.isComposing) { event.preventDefault(); buttons[0].click(); }
    });
  }
  dialog.showModal();
  const input = dialog.querySelector("input, select");
  (input || buttons[1]).focus();
}

function confirmQuestion(message) {
  ask(message.question, [], "Yes", () => command("answer", { qid: message.qid, yes: true }), "No",
    () => command("answer", { qid: message.qid, yes: false }));
  $("#ask").dataset.qid = message.qid;   // a question the server withdraws closes ("withdrawn")
}

function showReply(message) {
  if (message.cmd === "default_name" && message.ok && pendingRecord) {
    pendingRecord = false;
    ask("Record the arm's pose as:", [field("name", "name", message.text)], "OK",
      (values) => { selectNewStep(); command("record", { name: values.name, after: selected }); });
    return;
  }
  if (message.cmd === "jog_stop" && message.ok) return;
  const notice = $("#notice");
  if (message.ok && message.text === "asked") return;
  notice.textContent = message.ok ? message.text : `Error: ${message.error}`;
  notice.className = message.ok ? "" : "error";
  notice.setAttribute("role", message.ok ? "status" : "alert");
}

// ---------------------------------------------------------------------------------------------------- start
const workerEarly = [];   // what the drawing worker said before the view was made
// The drawing worker, started on the canvas (handed over as an OffscreenCanvas); null where the browser cannot.
function startWorker(canvas) {
  if (!canvas.transferControlToOffscreen || !window.Worker) return null;
  const worker = new Worker(new URL("./draw_worker.js", import.meta.url), { type: "module" });
  const offscreen = canvas.transferControlToOffscreen();
  worker.postMessage({ type: "start", canvas: offscreen, ratio: Math.min(window.devicePixelRatio || 1, 2) },
    [offscreen]);
  worker.onmessage = (event) => workerEarly.push(event.data);   // until the view takes over (showView)
  return worker;
}

// The 3D view once three.js is loaded: it is given what came before it (the scene, the frames, a check, the arm).
function showView(made) {
  view = made;
  screen.view = view;
  view.onArmDrawn = () => { screen.firstArmDrawnAt = Date.now(); document.body.dataset.armDrawn = "true"; };
  workerEarly.splice(0).forEach((message) => view.fromWorker(message));
  if (scene) { view.setArm(scene.arm); view.setCell(scene.cell); }
  if (program.frames) view.setFrames(program.frames);
  if (check) view.setCheck(check);
  if (state && state.arm) view.placeArm(state.arm);
}

function noView(error) {
  console.error(`no 3D view: ${error}`);
  view = null;
  $("#no-webgl").hidden = false;
}

function start() {
  const worker = startWorker($("#scene"));
  connect();
  buildJog();
  buildIO();
  showJogSpeed();
  refreshButtons();
  if (!worker) noView(new Error("this browser cannot draw off the page"));
  else import("./view3d.js").then(({ View3D }) => showView(new View3D($("#scene"), worker))).catch(noView);
}

start();
