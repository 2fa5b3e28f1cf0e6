// The clrender viewer's page: frames from the WebSocket (clrender/view/frames.py), tone-mapped
// here (the formulas of clrender/view/tonemap.py), camera moves and the save action sent back
// (clrender/view/server.py describes the protocol).
"use strict";

const $ = (id) => document.getElementById(id);
const canvas = $("image");
const context = canvas.getContext("2d");
const FLOAT32_MAX = 3.4028234663852886e38;

// Tone-map curves after exposure, in float32 steps as numpy computes them (tonemap.py).
const f = Math.fround;
const CURVES = {
  clamp: (x) => x,
  reinhard: (x) => { x = Math.max(x, 0); return f(x / f(1 + x)); },
  aces: (x) => {
    x = Math.max(x, 0);
    return f(f(x * f(f(2.51 * x) + 0.03)) / f(f(x * f(f(2.43 * x) + 0.59)) + 0.14));
  },
};

function toByte(value, scale, curve) {
  // image.tonemap: NaN -> 0, +inf -> 1 before the exposure; then clip and the sRGB curve.
  if (Number.isNaN(value)) value = 0;
  else if (value === Infinity) value = 1;
  else if (value === -Infinity) value = -FLOAT32_MAX;
  let x = curve(f(value * scale));
  x = Math.min(Math.max(x, 0), 1);
  const s = x <= 0.0031308 ? f(12.92 * x) : f(f(1.055 * f(Math.pow(x, 1 / 2.4))) - 0.055);
  return Math.round(f(s * 255));
}

const state = {
  socket: null, hello: null, frame: null, generation: -1, layer: "image",
  exposure: 0, tonemap: "clamp", frames: 0,
};

function decodeFrame(buffer) {
  const length = new DataView(buffer).getUint32(0, true);
  const header = JSON.parse(new TextDecoder().decode(new Uint8Array(buffer, 4, length)));
  const pixels = header.kind === "radiance"
    ? new Float32Array(buffer, 4 + length) : new Uint8Array(buffer, 4 + length);
  return { header, pixels };
}

function draw() {
  const frame = state.frame;
  if (!frame) return;
  const { width, height, kind } = frame.header;
  if (canvas.width !== width || canvas.height !== height) {
    canvas.width = width;
    canvas.height = height;
    fitCanvas();
  }
  const image = context.createImageData(width, height);
  const out = image.data, source = frame.pixels;
  const scale = f(Math.pow(2, state.exposure)), curve = CURVES[state.tonemap];
  for (let p = 0, q = 0; p < source.length; p += 3, q += 4) {
    for (let c = 0; c < 3; c++) {
      out[q + c] = kind === "radiance" ? toByte(source[p + c], scale, curve) : source[p + c];
    }
    out[q + 3] = 255;
  }
  context.putImageData(image, 0, 0);
  state.frames += 1;
  document.body.dataset.frames = state.frames;
  canvas.dispatchEvent(new CustomEvent("frame", { detail: frame.header }));
}

function fitCanvas() {
  // As large as the window allows; small images by whole multiples, with sharp pixels.
  const main = canvas.parentElement;
  const fit = Math.min(main.clientWidth / canvas.width, main.clientHeight / canvas.height);
  const scale = fit >= 1 ? Math.max(1, Math.floor(fit)) : fit;
  canvas.style.width = `${canvas.width * scale}px`;
  canvas.style.height = `${canvas.height * scale}px`;
  canvas.classList.toggle("pixelated", scale >= 2);
}

function showStatus() {
  const header = state.frame && state.frame.header;
  if (!header) return;
  // With the Sobol sampler the variance AOV bounds the noise from above (frames.py).
  const bound = header.noise_bound ? "≤ " : "";
  const noise = header.noise === null ? "–" : `${bound}${(100 * header.noise).toFixed(2)} %`;
  let text = `${header.layer} · ${header.samples} / ${header.target} spp · ` +
    `${(header.samples_per_second / 1e6).toFixed(2)} M samples/s · noise ${noise}`;
  if (header.noise !== null && header.noise > 0.01 && !header.done) {
    const needed = Math.ceil(header.samples * (header.noise / 0.01) ** 2);
    text += ` (${bound || "≈ "}${needed} spp to 1 %)`;
  }
  text += header.done ? " · done" : ` · rendering ${header.seconds.toFixed(1)} s`;
  $("status").textContent = text;
  $("camera").textContent = JSON.stringify(header.camera);
  document.body.dataset.samples = header.samples;
  document.body.dataset.layer = header.layer;
  document.body.dataset.generation = header.generation;
}

function showMessage(text, error) {
  $("message").textContent = text;
  $("message").classList.toggle("error", Boolean(error));
}

function send(message) {
  if (state.socket && state.socket.readyState === WebSocket.OPEN) state.socket.send(JSON.stringify(message));
}

function onHello(hello) {
  state.hello = hello;
  $("title").textContent = hello.scene;
  document.title = `${hello.scene} – clrender view`;
  const layer = $("layer"), tonemap = $("tonemap");
  layer.replaceChildren(...hello.layers.map((name, i) => new Option(`${i + 1} ${name}`, name)));
  tonemap.replaceChildren(...hello.tonemaps.map((name) => new Option(name, name)));
  layer.value = state.layer;
  tonemap.value = state.tonemap;
  send({ type: "layer", layer: state.layer });
  showMessage(`save writes ${hello.paths.join(" and ")}`);
}

function onFrame(frame) {
  const header = frame.header;
  if (header.layer !== state.layer || header.generation < state.generation) return;  // stale
  state.generation = header.generation;
  state.frame = frame;
  draw();
  showStatus();
}

function connect() {
  const url = new URL("socket", location.href);
  url.protocol = location.protocol === "https:" ? "wss:" : "ws:";
  const socket = new WebSocket(url);
  socket.binaryType = "arraybuffer";
  socket.onmessage = (event) => {
    if (typeof event.data !== "string") { onFrame(decodeFrame(event.data)); return; }
    const message = JSON.parse(event.data);
    if (message.type === "hello") onHello(message);
    else if (message.type === "saved") {
      showMessage(`saved ${message.paths.join(" and ")} (${message.samples} spp)`);
      document.body.dataset.saved = message.paths.join("\n");
    } else if (message.type === "error") showMessage(message.message, true);
  };
  socket.onclose = () => {
    document.body.classList.add("closed");
    document.body.dataset.closed = "1";
    $("status").textContent = "the viewer has stopped";
  };
  state.socket = socket;
}

// --- controls -----------------------------------------------------------------------------

function setExposure(stops) {
  state.exposure = Math.min(10, Math.max(-10, Math.round(stops * 10) / 10));
  $("exposure").value = state.exposure;
  $("exposure-value").textContent = state.exposure.toFixed(1);
  draw();
}

function setLayer(name) {
  state.layer = name;
  $("layer").value = name;
  send({ type: "layer", layer: name });
}

function save() {
  showMessage("saving…");
  send({ type: "save", layer: state.layer, exposure: state.exposure, tonemap: state.tonemap });
}

$("exposure").addEventListener("input", (e) => setExposure(Number(e.target.value)));
$("tonemap").addEventListener("change", (e) => { state.tonemap = e.target.value; draw(); });
$("layer").addEventListener("change", (e) => setLayer(e.target.value));
$("reset").addEventListener("click", () => send({ type: "reset" }));
$("save").addEventListener("click", save);
$("stop").addEventListener("click", () => send({ type: "stop" }));
window.addEventListener("resize", fitCanvas);

document.addEventListener("keydown", (e) => {
  if (e.ctrlKey || e.metaKey || e.altKey || e.target.tagName === "SELECT") return;
  const key = e.key.toLowerCase();
  if (key === "r") send({ type: "reset" });
  else if (key === "s") save();
  else if (key === "+" || key === "=") setExposure(state.exposure + 0.5);
  else if (key === "-") setExposure(state.exposure - 0.5);
  else if (key === "0") setExposure(0);
  else if (state.hello && key >= "1" && key <= "9" && Number(key) <= state.hello.layers.length) {
    setLayer(state.hello.layers[Number(key) - 1]);
  } else return;
  e.preventDefault();
});

// Mouse: drag orbits (shift or the right button: pans), the wheel zooms. Moves are summed and
// sent once per animation frame: each restarts the render.
const pending = { yaw: 0, pitch: 0, dx: 0, dy: 0, zoom: 1 };
let drag = null, scheduled = false;

function flush() {
  scheduled = false;
  if (pending.yaw || pending.pitch) send({ type: "orbit", yaw: pending.yaw, pitch: pending.pitch });
  if (pending.dx || pending.dy) send({ type: "pan", dx: pending.dx, dy: pending.dy });
  if (pending.zoom !== 1) send({ type: "zoom", factor: Math.min(100, Math.max(0.01, pending.zoom)) });
  Object.assign(pending, { yaw: 0, pitch: 0, dx: 0, dy: 0, zoom: 1 });
}

function schedule() {
  if (!scheduled) { scheduled = true; requestAnimationFrame(flush); }
}

canvas.addEventListener("contextmenu", (e) => e.preventDefault());
canvas.addEventListener("pointerdown", (e) => {
  drag = { x: e.clientX, y: e.clientY, pan: e.shiftKey || e.button !== 0 };
  canvas.setPointerCapture(e.pointerId);
  canvas.classList.add("dragging");
});
canvas.addEventListener("pointermove", (e) => {
  if (!drag) return;
  const box = canvas.getBoundingClientRect();
  const dx = (e.clientX - drag.x) / box.width, dy = (e.clientY - drag.y) / box.height;
  drag.x = e.clientX;
  drag.y = e.clientY;
  if (drag.pan) { pending.dx += dx; pending.dy += dy; }
  else { pending.yaw -= dx * Math.PI; pending.pitch += dy * Math.PI; }  // the scene follows the pointer
  schedule();
});
const endDrag = () => { drag = null; canvas.classList.remove("dragging"); };
canvas.addEventListener("pointerup", endDrag);
canvas.addEventListener("pointercancel", endDrag);
canvas.addEventListener("wheel", (e) => {
  e.preventDefault();
  const notches = e.deltaMode === 0 ? e.deltaY / 100 : e.deltaY / 3;
  pending.zoom *= Math.exp(0.1 * Math.max(-5, Math.min(5, notches)));
  schedule();
}, { passive: false });

connect();
