// grammarkit studio: the page. Talks to the server over one websocket (see app.py).
// No build step: three.js is loaded as ES modules from static/vendor, CodeMirror 5 as scripts.
import * as THREE from "./vendor/three/three.module.js";
import { OrbitControls } from "./vendor/three/examples/jsm/controls/OrbitControls.js";
import { GLTFLoader } from "./vendor/three/examples/jsm/loaders/GLTFLoader.js";

const $ = (id) => document.getElementById(id);
const EDIT_DEBOUNCE_MS = 120; // typing: wait for a pause this long before re-deriving

// ---------------------------------------------------------------------------------------------
// state
const S = {
  ws: null, rev: 0, shownRev: -1, text: "", diskText: "", diskHash: null, fileName: "",
  filePath: "", attrs: {}, seed: 0, variation: null, example: 0, sliders: [], family: null,
  sent: new Map(), // rev -> performance.now() when the edit was made
  latencies: [], // [rev, ms from edit to rendered frame]
  lastCheck: null, tree: null, treeRev: -1, selectedNode: null, frameNode: null,
  galleryId: 0, models: 0, errors: [], lastFacts: null, lineMark: null,
};
window.studio = S; // for the browser tests and the benchmark

// ---------------------------------------------------------------------------------------------
// editor: CodeMirror 5 with the TextMate grammar from editors/vscode turned into a simple mode
const TOKEN_OF_SCOPE = [
  ["comment", "comment"], ["string", "string"], ["storage.modifier", "meta"],
  ["keyword.operator", "operator"], ["keyword", "keyword"], ["constant.numeric", "number"],
  ["constant.language", "atom"], ["entity.name.function", "def"], ["entity.name.tag", "tag"],
  ["support.function", "builtin"], ["variable.other.member", "property"],
  ["entity.name.type", "variable-2"], ["variable", "variable"],
];
function tokenFor(scope) {
  for (const [prefix, token] of TOKEN_OF_SCOPE) if (scope.startsWith(prefix)) return token;
  return null;
}
async function defineMode() {
  const tm = await (await fetch("static/grammarkit.tmLanguage.json")).json();
  const rules = tm.patterns.map((p) => ({ regex: new RegExp(p.match), token: tokenFor(p.name) }));
  rules.push({ regex: /\s+/, token: null }, { regex: /./, token: null });
  CodeMirror.defineSimpleMode("grammarkit", { start: rules, meta: { lineComment: "#" } });
}

let cm = null;
let marks = [];
function makeEditor(text) {
  cm = CodeMirror($("editor"), {
    value: text, mode: "grammarkit", theme: "gk", lineNumbers: true, lineWrapping: true,
    indentUnit: 2, tabSize: 2,
    lineSeparator: text.includes("\r\n") ? "\r\n" : null, // saving keeps the file's line ends
    gutters: ["gk-diagnostics", "CodeMirror-linenumbers"], extraKeys: {
      Tab: (c) => c.replaceSelection("  "),
    },
  });
  // the reverse link from the text: the cursor on a rule's line outlines the parts it made
  let lineTimer = null;
  cm.on("cursorActivity", () => {
    clearTimeout(lineTimer);
    lineTimer = setTimeout(() => {
      if (!S.tree || S.treeRev !== S.shownRev || S.sent.size || S.text !== cm.getValue()) return;
      const line = cm.getCursor().line + 1;
      if (line === S.cursorLine) return;
      S.cursorLine = line;
      const ids = S.tree.nodes.filter((n) => n[5] === line && S.tree.files[n[4]] === S.filePath).map((n) => n[0]);
      if (ids.length) send({ op: "node", ids: ids.slice(0, 10000) });
    }, 250);
  });
  let timer = null;
  cm.on("change", () => {
    S.text = cm.getValue();
    updateDirty();
    clearTimeout(timer);
    timer = setTimeout(() => sendEdit(), EDIT_DEBOUNCE_MS);
  });
}

function showDiagnostics(diags) {
  cm.operation(() => {
    for (const m of marks) m.clear();
    marks = [];
    cm.clearGutter("gk-diagnostics");
    const here = (d) => !d.file || d.file === S.filePath;
    const byLine = new Map();
    for (const d of diags) {
      if (!here(d) || !d.line) continue;
      const line = d.line - 1;
      const from = { line, ch: Math.max(0, (d.column || 1) - 1) };
      let to = { line: (d.end_line || d.line) - 1, ch: Math.max(0, (d.end_column || d.column + 1) - 1) };
      if (to.line < from.line || (to.line === from.line && to.ch <= from.ch)) to = { line, ch: from.ch + 1 };
      marks.push(cm.markText(from, to, { className: `gk-underline-${d.severity}`, title: d.message }));
      if (!byLine.has(line)) byLine.set(line, []);
      byLine.get(line).push(d);
    }
    for (const [line, list] of byLine) {
      const dot = document.createElement("div");
      dot.className = `gk-gutter ${list.some((d) => d.severity === "error") ? "error" : "warning"}`;
      dot.title = list.map((d) => d.message).join("\n");
      cm.setGutterMarker(line, "gk-diagnostics", dot);
      for (const d of list) {
        const w = document.createElement("div");
        w.className = `gk-diag ${d.severity}`;
        w.textContent = `${d.severity}: ${d.message}`;
        if (d.hint) {
          const h = document.createElement("span");
          h.className = "hint";
          h.textContent = d.hint;
          w.appendChild(h);
        }
        marks.push(cm.addLineWidget(line, w, { coverGutter: false, noHScroll: true }));
      }
    }
  });
  const box = $("problems");
  box.textContent = "";
  if (!diags.length) {
    box.innerHTML = '<span class="ok">no problems</span>';
    return;
  }
  for (const d of diags) {
    const el = document.createElement("div");
    el.className = `item ${d.severity}`;
    const where = d.line ? `${d.file && d.file !== S.filePath ? shortPath(d.file) : S.fileName}:${d.line}:${d.column}` : (d.file || "");
    el.textContent = `${where}: ${d.severity}: ${d.message}`;
    el.onclick = () => { if (here(d) && d.line) { cm.setCursor(d.line - 1, Math.max(0, d.column - 1)); cm.focus(); } };
    box.appendChild(el);
  }
  function here(d) { return !d.file || d.file === S.filePath; }
}
const shortPath = (p) => (p || "").split("/").slice(-1)[0];

function highlightSource(file, line) {
  if (S.lineMark !== null) { cm.removeLineClass(S.lineMark, "background", "gk-src-line"); S.lineMark = null; }
  if (!line || (file && file !== S.filePath)) return;
  S.lineMark = line - 1;
  cm.addLineClass(S.lineMark, "background", "gk-src-line");
  cm.scrollIntoView({ line: line - 1, ch: 0 }, 80);
}

// ---------------------------------------------------------------------------------------------
// 3D view
const view = $("view");
const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
renderer.setPixelRatio(Math.min(window.devicePixelRatio, 2));
renderer.outputColorSpace = THREE.SRGBColorSpace;
view.appendChild(renderer.domElement);
const scene = new THREE.Scene();
const BACKGROUND = new THREE.Color("#2b3036");
scene.background = BACKGROUND;
const camera = new THREE.PerspectiveCamera(40, 1, 0.1, 5000);
camera.position.set(40, 30, 50);
const controls = new OrbitControls(camera, renderer.domElement);
controls.enableDamping = false;
controls.addEventListener("change", () => render());
scene.add(new THREE.HemisphereLight(0xdfe8f0, 0x4a4238, 1.6));
const sun = new THREE.DirectionalLight(0xffffff, 2.2);
sun.position.set(30, 60, 40);
scene.add(sun);
const grid = new THREE.GridHelper(200, 40, 0x555d66, 0x3a4047);
scene.add(grid);
const modelRoot = new THREE.Group();
scene.add(modelRoot);
const highlight = new THREE.Group(); // boxes of the selected parts, in the model's frame
const loader = new GLTFLoader();
let framed = false;

function resize() {
  const w = view.clientWidth, h = view.clientHeight;
  renderer.setSize(w, h, false);
  renderer.domElement.style.width = w + "px";
  renderer.domElement.style.height = h + "px";
  camera.aspect = w / Math.max(1, h);
  camera.updateProjectionMatrix();
  render();
}
window.addEventListener("resize", resize);
function render() { renderer.render(scene, camera); }

function frameModel(object) {
  const box = new THREE.Box3().setFromObject(object);
  if (box.isEmpty()) return;
  const size = box.getSize(new THREE.Vector3()), center = box.getCenter(new THREE.Vector3());
  const r = Math.max(0.5 * size.length(), 1e-3); // bounding sphere radius
  const dist = (1.15 * r) / Math.sin((camera.fov * Math.PI) / 360) / Math.min(1, camera.aspect);
  controls.target.copy(center);
  camera.position.copy(center).add(new THREE.Vector3(0.55, 0.35, 0.76).normalize().multiplyScalar(dist));
  camera.near = r / 500; camera.far = r * 50;
  camera.updateProjectionMatrix();
  controls.update();
  grid.position.y = box.min.y;
}

// The node whose local frame is the model's own (Z up, metres). grammarkit's glTF layout 2
// puts the Z-up -> Y-up rotation on the root node (extras.grammarkit.up = "+Z"); an older
// file has no rotation, so the view rotates it upright itself.
function modelFrameOf(gltfScene) {
  const root = gltfScene.children.length === 1 ? gltfScene.children[0] : null;
  const marker = root && root.userData && root.userData.grammarkit;
  if (marker && marker.up === "+Z") return { node: root, upright: true };
  return { node: gltfScene, upright: false };
}

function showGLB(buffer, onShown, isStale) {
  const t0 = performance.now();
  loader.parse(buffer, "", (gltf) => {
    if (isStale && isStale()) { disposeTree(gltf.scene); return; } // a newer model was shown meanwhile
    const t1 = performance.now();
    applyRuns(gltf.scene);
    const frame = modelFrameOf(gltf.scene);
    const holder = new THREE.Group();
    if (!frame.upright) holder.rotation.x = -Math.PI / 2;
    holder.add(gltf.scene);
    for (const old of [...modelRoot.children]) { modelRoot.remove(old); disposeTree(old); }
    modelRoot.add(holder);
    holder.updateMatrixWorld(true);
    S.frameNode = frame.node;
    if (highlight.parent) highlight.parent.remove(highlight);
    frame.node.add(highlight);
    clearHighlight();
    $("selection").hidden = true; // the picked part belonged to the old model
    if (!framed) { frameModel(modelRoot); framed = true; }
    render();
    S.timing = { parse_ms: t1 - t0, render_ms: performance.now() - t1 };
    S.models += 1;
    if (onShown) onShown();
  }, (err) => setError({ message: `could not show the model: ${err.message || err}` }));
}
// A closed solid is ONE glTF primitive (so that it reads back watertight everywhere); its
// terminals' materials ride in the primitive's extras as runs of triangles (docs/derive.md,
// "Files"). Give each run its material back as a three.js geometry group.
function applyRuns(scene) {
  scene.traverse((o) => {
    const gk = o.isMesh && o.geometry.userData && o.geometry.userData.grammarkit;
    if (!gk || !Array.isArray(gk.runs) || !Array.isArray(gk.materials)) return;
    const base = Array.isArray(o.material) ? o.material[0] : o.material;
    const mats = gk.materials.map((m) => {
      const pbr = m.pbrMetallicRoughness || {};
      const c = pbr.baseColorFactor || [1, 1, 1, 1];
      const mat = base.clone();
      mat.name = m.name || "";
      mat.color.setRGB(c[0], c[1], c[2]); // glTF colour factors are linear, as three's working space
      mat.metalness = pbr.metallicFactor ?? 1;
      mat.roughness = pbr.roughnessFactor ?? 1;
      mat.opacity = c[3] ?? 1;
      mat.transparent = mat.opacity < 1;
      return mat;
    });
    o.geometry.clearGroups();
    for (const [, m, first, count] of gk.runs) o.geometry.addGroup(first * 3, count * 3, m);
    base.dispose();
    o.material = mats;
  });
}
function disposeTree(obj) {
  obj.traverse((o) => {
    if (o.geometry) o.geometry.dispose();
    if (o.material) (Array.isArray(o.material) ? o.material : [o.material]).forEach((m) => m.dispose());
  });
}

// boxes around parts: a part is a scope (origin, axes, size) in the model frame
function clearHighlight() {
  for (const c of [...highlight.children]) { highlight.remove(c); c.geometry.dispose(); }
  S.highlighted = 0;
}
function showParts(parts) {
  clearHighlight();
  if (!parts.length) { render(); return; }
  const pos = [];
  const EDGES = [[0, 1], [1, 3], [3, 2], [2, 0], [4, 5], [5, 7], [7, 6], [6, 4], [0, 4], [1, 5], [2, 6], [3, 7]];
  for (const p of parts) {
    const corners = [];
    const s = p.size.map((v) => (v > 0 ? v : 0.02));
    for (let k = 0; k < 8; k++) {
      const f = [k & 1 ? s[0] : 0, k & 2 ? s[1] : 0, k & 4 ? s[2] : 0];
      const c = [0, 1, 2].map((i) => p.origin[i] + f[0] * p.axes[0][i] + f[1] * p.axes[1][i] + f[2] * p.axes[2][i]);
      corners.push(c);
    }
    for (const [a, b] of EDGES) pos.push(...corners[a], ...corners[b]);
  }
  const g = new THREE.BufferGeometry();
  g.setAttribute("position", new THREE.Float32BufferAttribute(pos, 3));
  const lines = new THREE.LineSegments(g, new THREE.LineBasicMaterial({ color: 0xffb020, depthTest: false }));
  lines.renderOrder = 10;
  highlight.add(lines);
  S.highlighted = parts.length;
  render();
}

// model-frame point <-> screen (tests use these to find and click parts)
S.project = (p) => {
  const v = new THREE.Vector3(...p);
  S.frameNode.localToWorld(v);
  v.project(camera);
  const r = renderer.domElement.getBoundingClientRect();
  return { x: r.left + (v.x + 1) / 2 * r.width, y: r.top + (1 - v.y) / 2 * r.height, depth: v.z };
};
S.hitAt = (clientX, clientY) => {
  const hit = raycast(clientX, clientY);
  if (!hit) return null;
  return { point: S.frameNode.worldToLocal(hit.point.clone()).toArray(), terminal: terminalOfHit(hit) };
};
S.render = render;

const raycaster = new THREE.Raycaster();
function raycast(clientX, clientY) {
  const r = renderer.domElement.getBoundingClientRect();
  const ndc = new THREE.Vector2(((clientX - r.left) / r.width) * 2 - 1, -((clientY - r.top) / r.height) * 2 + 1);
  raycaster.setFromCamera(ndc, camera);
  const hits = raycaster.intersectObject(modelRoot, true).filter((h) => h.object.isMesh);
  return hits.length ? hits[0] : null;
}
// On a one-primitive solid the terminals are child nodes without a mesh, and the hit face's
// run (see applyRuns) names the child: runs are [child, material, first face, face count].
function terminalOfHit(hit) {
  const gk = hit.object.geometry && hit.object.geometry.userData && hit.object.geometry.userData.grammarkit;
  if (gk && Array.isArray(gk.runs) && hit.faceIndex != null) {
    const run = gk.runs.find(([, , first, count]) => hit.faceIndex >= first && hit.faceIndex < first + count);
    const node = run && hit.object.children[run[0]];
    if (node && node.userData && typeof node.userData.terminal === "string") return node.userData.terminal;
  }
  return terminalOf(hit.object);
}
function terminalOf(object) {
  for (let o = object; o; o = o.parent) {
    const u = o.userData || {};
    if (typeof u.terminal === "string") return u.terminal;
  }
  return null;
}

let down = null;
renderer.domElement.addEventListener("pointerdown", (e) => { down = [e.clientX, e.clientY]; });
renderer.domElement.addEventListener("pointerup", (e) => {
  if (!down || Math.hypot(e.clientX - down[0], e.clientY - down[1]) > 4) return; // a drag orbits
  const hit = S.hitAt(e.clientX, e.clientY);
  if (!hit) { clearSelection(); return; }
  if (S.family === "split") send({ op: "pick", point: hit.point, terminal: hit.terminal, rev: S.shownRev });
});

// ---------------------------------------------------------------------------------------------
// server connection
function send(msg) { if (S.ws && S.ws.readyState === 1) S.ws.send(JSON.stringify(msg)); }

function connect() {
  const url = `ws://${location.host}${location.pathname.replace(/\/?$/, "/")}ws`;
  const ws = new WebSocket(url);
  ws.binaryType = "arraybuffer";
  S.ws = ws;
  ws.onopen = () => status("connected");
  ws.onclose = () => {
    status("disconnected: restart `grammarkit studio` and reload");
    if (S.sketchBusy) { S.sketchBusy = false; sketchResult("disconnected before the recognizer answered", "error"); }
  };
  ws.onmessage = (ev) => (typeof ev.data === "string" ? onJSON(JSON.parse(ev.data)) : onBinary(ev.data));
}

function unpack(buffer) {
  const n = new DataView(buffer).getUint32(0);
  const header = JSON.parse(new TextDecoder().decode(new Uint8Array(buffer, 4, n)));
  const parts = [];
  let at = 4 + n;
  for (const size of header.sizes) { parts.push(buffer.slice(at, at + size)); at += size; }
  return [header, parts];
}

function onBinary(buffer) {
  const [h, parts] = unpack(buffer);
  if (h.type === "model") {
    if (h.rev < S.shownRev) return;
    showGLB(parts[0], () => {
      S.shownRev = h.rev;
      S.lastFacts = h.facts;
      const t0 = S.sent.get(h.rev);
      if (t0 !== undefined) {
        const ms = performance.now() - t0;
        S.latencies.push([h.rev, ms, h.facts.server_ms, S.timing.parse_ms, S.timing.render_ms, h.facts.derive_ms, h.facts.export_ms, h.facts.work_ms]);
        for (const r of [...S.sent.keys()]) if (r <= h.rev) S.sent.delete(r);
        showFacts(h.facts, ms);
      }
      $("derive-error").hidden = true;
      exportFrom(null);
      S.tree = null;
      if ($("tree-panel").open) scheduleTree();
    }, () => h.rev < S.shownRev);
  } else if (h.type === "gallery-item") {
    addCard(h, parts[0], parts[1]);
  }
}

function onJSON(m) {
  switch (m.type) {
    case "file":
      S.fileName = m.name; S.filePath = m.path; S.diskText = m.text; S.diskHash = m.hash;
      $("filename").textContent = "\u200e" + m.path; // LRM: ellipsis on the left, slashes in place
      document.title = `${m.name} · grammarkit studio`;
      if (!cm) makeEditor(m.text); else cm.setValue(m.text);
      S.text = m.text;
      updateDirty();
      sendEdit();
      break;
    case "check":
      if (m.rev < S.lastCheckRev) break;
      S.lastCheckRev = m.rev;
      S.lastCheck = m;
      S.family = m.family || S.family;
      {
        const key = JSON.stringify(m.diagnostics || []);
        if (key !== S.diagKey) { S.diagKey = key; showDiagnostics(m.diagnostics || []); } // slider edits: unchanged
      }
      if (m.ok) updateSliders(m.sliders || []);
      if (m.ok) requestBackends();
      if (!m.ok) {
        forget(m.rev); // no model comes for this edit
        status(`${(m.diagnostics || []).filter((d) => d.severity === "error").length} error(s): the last good model is shown`);
      }
      break;
    case "derive-error":
      forget(m.rev);
      setError(m);
      break;
    case "tree":
      S.tree = m; S.treeRev = m.rev;
      if (S.afterTree) { const then = S.afterTree; S.afterTree = null; then(); } else renderTree();
      break;
    case "pick":
      onPick(m); break;
    case "node":
      showParts(m.parts || []); break;
    case "saved":
      S.diskHash = m.hash; S.diskText = S.savedText; updateDirty(); status(`saved ${shortPath(m.path)}`); break;
    case "save-conflict":
      ask(`${S.fileName} changed on disk since you opened it. Overwrite it with your text?`,
        "Overwrite", "Cancel").then((yes) => { if (yes) save(true); else status("not saved"); });
      break;
    case "disk-changed":
      onDiskChanged(m); break;
    case "formatted":
      cm.setValue(m.text); break;
    case "backends":
      fillBackends(m); break;
    case "gallery-done":
      if (m.gallery !== S.galleryId) break;
      $("gallery-status").textContent = m.stopped ? "stopped" :
        `${m.count} of ${m.requested} in ${m.seconds} s${m.shortfall ? ": " + m.shortfall : ""}`;
      break;
    case "gallery-error":
      if (m.gallery === S.galleryId) $("gallery-status").textContent = m.message;
      break;
    case "sketch":
      onSketch(m); break;
    case "sketch-canvas":
      onSketchCanvas(m); break;
    case "error":
      if (m.op === "sketch") { onSketchError(m); break; }
      if (m.op === "sketch-canvas") { sketchResult(m.message, "error"); break; }
      if (m.op === "pick" || m.op === "node" || m.op === "tree") status(m.message);
      else setError(m);
      break;
  }
}
S.lastCheckRev = -1;

function status(text) { $("status").textContent = text; }
// edits up to `rev` that will bring no model (errors): no longer waited for
function forget(rev) { if (typeof rev === "number") for (const r of [...S.sent.keys()]) if (r <= rev) S.sent.delete(r); }
function showFacts(f, ms) {
  const what = f.kind === "split" ? `${f.triangles} triangles · ${f.shapes} shapes` : `${f.parts} parts · example ${f.example}`;
  status(`${what} · derive ${f.derive_ms} ms · export ${f.export_ms} ms · shown in ${ms.toFixed(0)} ms`);
}
function setError(m) {
  const el = $("derive-error");
  el.textContent = (m.message || "failed") + "\n(the last good model is shown)";
  el.hidden = false;
  S.errors.push(m.message);
  if (m.diagnostics && m.diagnostics.length) { S.diagKey = null; showDiagnostics(m.diagnostics); }
}

// the Export links download the model in the view: a tiling variant from the gallery worker
function exportFrom(galleryIndex) {
  for (const fmt of ["glb", "obj", "stl"]) {
    $(`export-${fmt}`).setAttribute("href", galleryIndex === null ? `export/${fmt}` : `export/${fmt}?gallery=${galleryIndex}`);
  }
}

function sendEdit() {
  S.rev += 1;
  S.sent.set(S.rev, performance.now());
  send({ op: "edit", rev: S.rev, text: S.text, attrs: S.attrs, seed: S.seed, example: S.example,
         variation: S.variation });
}

// ---------------------------------------------------------------------------------------------
// sliders: one per @range attr, a choice per @enum attr
function updateSliders(list) {
  const names = list.map((s) => `${s.name}:${s.kind}:${s.min}:${s.max}:${(s.choices || []).join(",")}`).join("|");
  const box = $("sliders");
  if (names === S.sliderKey) {
    for (const s of list) {
      const input = box.querySelector(`[data-attr="${s.name}"]`);
      if (input && !(s.name in S.attrs) && document.activeElement !== input) setControl(input, s.value);
    }
    return;
  }
  S.sliderKey = names;
  S.sliders = list;
  box.textContent = "";
  if (!list.length) { box.innerHTML = '<span class="muted">no @range or @enum attrs</span>'; return; }
  for (const s of list) {
    const row = document.createElement("div");
    row.className = "slider";
    const label = document.createElement("div");
    label.className = "name";
    const value = document.createElement("span");
    value.className = "value";
    label.append(Object.assign(document.createElement("span"), { textContent: s.name }), value);
    row.appendChild(label);
    let input;
    if (s.kind === "range") {
      input = Object.assign(document.createElement("input"), { type: "range", min: s.min, max: s.max, step: s.step });
      input.addEventListener("input", () => { S.attrs[s.name] = Number(input.value); value.textContent = input.value; S.variation = null; sendEdit(); });
    } else {
      input = document.createElement("select");
      for (const c of s.choices) input.appendChild(Object.assign(document.createElement("option"), { value: JSON.stringify(c), textContent: String(c) }));
      input.addEventListener("change", () => { S.attrs[s.name] = JSON.parse(input.value); value.textContent = String(S.attrs[s.name]); S.variation = null; sendEdit(); });
    }
    input.dataset.attr = s.name;
    input.title = s.line ? `${S.fileName}:${s.line}` : "";
    row.appendChild(input);
    box.appendChild(row);
    setControl(input, s.name in S.attrs ? S.attrs[s.name] : s.value);
  }
}
function setControl(input, v) {
  if (input.tagName === "SELECT") input.value = JSON.stringify(v); else input.value = v;
  const val = input.parentElement.querySelector(".value");
  if (val) val.textContent = String(v);
}
$("reset-attrs").onclick = () => { S.attrs = {}; S.sliderKey = null; S.variation = null; sendEdit(); };

// ---------------------------------------------------------------------------------------------
// the derivation tree, linked both ways to the 3D view and the source
let treeTimer = null;
function scheduleTree() {
  clearTimeout(treeTimer);
  // asked for after the model is shown, once edits pause: the tree never delays a model
  treeTimer = setTimeout(() => { if (S.sent.size === 0) send({ op: "tree", rev: S.shownRev }); else scheduleTree(); }, 200);
}
$("tree-panel").addEventListener("toggle", () => { if ($("tree-panel").open && !S.tree) scheduleTree(); });

function renderTree(expandPath) {
  const box = $("tree");
  box.textContent = "";
  const t = S.tree;
  if (!t || !t.nodes.length) { box.textContent = S.family === "split" ? "" : "(no derivation tree: tiling grammar)"; return; }
  const kids = new Map();
  for (const n of t.nodes) { if (!kids.has(n[1])) kids.set(n[1], []); kids.get(n[1]).push(n); }
  S.treeKids = kids;
  S.treeById = new Map(t.nodes.map((n) => [n[0], n]));
  const open = new Set(expandPath || S.openNodes || [0]);
  S.openNodes = open;
  const add = (n, depth) => {
    const row = document.createElement("div");
    row.className = "node";
    row.style.setProperty("--depth", depth);
    row.dataset.id = n[0];
    const has = kids.has(n[0]);
    const file = t.files[n[4]];
    row.innerHTML = `<span class="toggle">${has ? (open.has(n[0]) ? "▾" : "▸") : ""}</span>`;
    row.append(n[2]);
    if (n[3] !== "rule" && n[3] !== "axiom") row.append(Object.assign(document.createElement("span"), { className: "via", textContent: ` (${n[3]})` }));
    if (n[6]) row.append(Object.assign(document.createElement("span"), { className: "term", textContent: ` → ${n[6]}.` }));
    if (n[5]) row.append(Object.assign(document.createElement("span"), { className: "line", textContent: `  ${shortPath(file)}:${n[5]}` }));
    if (n[6]) row.dataset.terminal = n[6];
    row.dataset.rule = n[2];
    if (S.selectedNode === n[0]) row.classList.add("selected");
    row.onclick = (e) => {
      if (e.target.classList.contains("toggle") && has) {
        if (open.has(n[0])) open.delete(n[0]); else open.add(n[0]);
        renderTree([...open]);
        return;
      }
      selectNode(n[0], true);
    };
    box.appendChild(row);
    if (has && open.has(n[0])) for (const c of kids.get(n[0])) add(c, depth + 1);
  };
  for (const root of kids.get(-1) || []) add(root, 0);
}

function selectNode(id, from3dToo) {
  S.selectedNode = id;
  for (const el of $("tree").querySelectorAll(".node.selected")) el.classList.remove("selected");
  const row = $("tree").querySelector(`.node[data-id="${id}"]`);
  if (row) {
    row.classList.add("selected");
    const box = $("tree"); // scroll the tree only (scrollIntoView would scroll the page too)
    box.scrollTop = Math.max(0, row.offsetTop - box.clientHeight / 2);
  }
  const n = S.treeById && S.treeById.get(id);
  if (n) highlightSource(S.tree.files[n[4]], n[5]);
  if (from3dToo) send({ op: "node", ids: [id] });
}

function onPick(m) {
  const p = m.part;
  S.lastPick = m;
  showParts([p]);
  const info = $("selection");
  info.hidden = false;
  const src = m.source && m.source.line ? `${shortPath(m.source.file)}:${m.source.line}` : "";
  info.textContent = `${p.name}.  rule ${p.rule}${p.object_type ? "  (" + p.object_type + ")" : ""}  ${src}` +
    (p.material ? `\nmaterial ${p.material}` : "");
  if (m.source) highlightSource(m.source.file, m.source.line);
  const expand = () => {
    const open = S.openNodes || new Set([0]);
    for (const id of m.path) open.add(id);
    renderTree([...open]);
    selectNode(p.node, false);
  };
  if (!S.tree || S.treeRev !== S.shownRev) {
    S.afterTree = expand; // a tree that arrives after a pick expands to the picked part
    send({ op: "tree", rev: S.shownRev });
  } else expand();
}
function clearSelection() { clearHighlight(); render(); $("selection").hidden = true; }

// ---------------------------------------------------------------------------------------------
// saving, external edits
function updateDirty() { $("dirty").hidden = S.text === S.diskText; }
function save(force) {
  S.savedText = S.text;
  send({ op: "save", text: S.text, base: S.diskHash, force });
}
$("save").onclick = () => save(false);
document.addEventListener("keydown", (e) => {
  if ((e.ctrlKey || e.metaKey) && e.key === "s") { e.preventDefault(); save(false); } // not the browser's "save page"
});
$("format").onclick = () => send({ op: "format", text: S.text });

async function onDiskChanged(m) {
  if (m.hash === S.diskHash) return;
  if (S.text === S.diskText || S.text === m.text) {
    S.diskText = m.text; S.diskHash = m.hash;
    if (S.text !== m.text) { const c = cm.getCursor(); cm.setValue(m.text); cm.setCursor(c); }
    updateDirty();
    status(`reloaded ${S.fileName}: it changed on disk`);
    return;
  }
  const load = await ask(`${S.fileName} changed on disk, and you have unsaved edits. Load the file's version (your edits are lost) or keep yours?`,
    "Load the file", "Keep mine");
  if (load) { S.diskText = m.text; S.diskHash = m.hash; cm.setValue(m.text); }
  updateDirty();
}

function ask(text, yes, no) {
  const d = $("ask");
  $("ask-text").textContent = text;
  $("ask-yes").textContent = yes;
  $("ask-no").textContent = no;
  return new Promise((resolve) => {
    const done = (v) => { d.close(); resolve(v); };
    $("ask-yes").onclick = () => done(true);
    $("ask-no").onclick = () => done(false);
    d.showModal();
  });
}

// ---------------------------------------------------------------------------------------------
// seed, variations, gallery
$("seed").onchange = () => { S.seed = Math.trunc(Number($("seed").value)) || 0; S.variation = null; sendEdit(); };
$("reseed").onclick = () => {
  S.seed = Math.floor(Math.random() * 1e6); $("seed").value = S.seed; S.variation = null; sendEdit();
};
$("variations").onclick = () => { $("gallery-panel").open = true; startGallery(S.family === "split" ? "split" : null); };
$("sample").onclick = () => startGallery($("backend").value || null);
$("stop").onclick = () => send({ op: "gallery-stop" });

function requestBackends() {
  if (S.backendsFamily === S.family) return;
  S.backendsFamily = S.family;
  send({ op: "backends", text: S.text });
}
function fillBackends(m) {
  const sel = $("backend");
  sel.textContent = "";
  for (const b of m.backends) sel.appendChild(Object.assign(document.createElement("option"), { value: b, textContent: b }));
  if (m.family === "split" && m.backends.includes("split")) sel.value = "split";
}
function startGallery(backend) {
  S.galleryId += 1;
  S.gallerySeed = S.seed;
  $("gallery").textContent = "";
  $("gallery-status").textContent = "sampling…";
  send({ op: "gallery", id: S.galleryId, text: S.text, backend, seed: S.seed, attrs: S.attrs,
         n: Number($("gallery-n").value) || 8, iterations: Number($("gallery-it").value) || 2 });
}
function addCard(h, glb, png) {
  if (h.gallery !== S.galleryId) return; // a stopped or replaced gallery
  const card = document.createElement("div");
  card.className = "card";
  const img = document.createElement("img");
  img.src = URL.createObjectURL(new Blob([png], { type: "image/png" }));
  img.alt = h.id;
  card.dataset.id = h.id;
  card.appendChild(img);
  const title = document.createElement("div");
  const report = h.report;
  title.innerHTML = report ? `<span class="${report.ok ? "ok" : "bad"}">${report.ok ? "valid" : report.violations.length + " violation(s)"}</span> ` : "";
  title.append(`#${h.index}`);
  card.appendChild(title);
  if (h.report_text || h.variation) {
    const det = document.createElement("details");
    det.appendChild(Object.assign(document.createElement("summary"), { textContent: report ? "report" : "attrs" }));
    det.append(h.report_text || JSON.stringify(h.variation.attrs, null, 1));
    card.appendChild(det);
  }
  card.dataset.index = h.index;
  S.galleryParts = S.galleryParts || {};
  if (h.metrics && h.metrics.parts !== undefined) S.galleryParts[h.index] = h.metrics.parts;
  card.onclick = (e) => {
    if (e.target.closest(".card details")) return; // opening the report is not choosing
    for (const c of $("gallery").querySelectorAll(".card.selected")) c.classList.remove("selected");
    card.classList.add("selected");
    if (S.family === "split") { S.variation = h.index; S.seed = S.gallerySeed; sendEdit(); }
    else { framed = false; showGLB(glb); exportFrom(h.index); } // a variant can be much larger than the example
  };
  $("gallery").appendChild(card);
  $("gallery-status").textContent = `${$("gallery").children.length} so far…`;
}

// ---------------------------------------------------------------------------------------------
// sketch canvas (needs the grammarkit_sketch plugin on the server). As in Nishida et al.'s
// interface, each object type is drawn on its own canvas: the type's camera framed on the anchor
// (the part already built), whose outline the server sends as the paper. The canvas keeps the
// type's aspect ratio (the recognizer refuses other shapes); strokes are kept and sent in the
// canvas's own pixels, whatever size it is shown at.
const sketch = $("sketch");
const sketchPaper = new Image();
let strokes = [], drawing = null;
Object.defineProperty(S, "strokes", { get: () => strokes });
S.sketchCanvas = null; // {object_type, width, height, png} of the type shown
S.sketchBusy = false; // a recognition asked for and not answered yet
function sketchResult(text, cls) {
  const box = $("sketch-result");
  box.textContent = text || ""; box.className = cls || "";
}
function sketchButtons() {
  $("sketch-recognize").disabled = !S.sketchCanvas || S.sketchBusy;
}
function askSketchCanvas() {
  strokes = []; drawing = null; S.sketchCanvas = null; sketch.hidden = true; sketchButtons();
  const t = $("sketch-type").value;
  if (!t) { sketchResult("this grammar has no object types to sketch", "error"); return; }
  sketchResult(`loading the ${t} canvas…`);
  send({ op: "sketch-canvas", object_type: t, text: S.text });
}
$("sketch-toggle").onclick = () => {
  const on = $("sketch-tools").hidden;
  $("sketch-tools").hidden = !on;
  if (!on) { sketch.hidden = true; return; }
  const sel = $("sketch-type"), was = sel.value;
  sel.textContent = "";
  for (const t of (S.lastCheck && S.lastCheck.object_types) || []) sel.appendChild(Object.assign(document.createElement("option"), { value: t, textContent: t }));
  if (was && [...sel.options].some((o) => o.value === was)) sel.value = was;
  askSketchCanvas();
};
$("sketch-type").onchange = askSketchCanvas;
function onSketchCanvas(m) {
  if ($("sketch-tools").hidden || m.object_type !== $("sketch-type").value) return; // an old answer
  sketchPaper.onload = () => {
    S.sketchCanvas = m;
    sketch.width = m.width; sketch.height = m.height;
    sketch.hidden = false;
    layoutSketch(); drawStrokes(); sketchButtons();
    sketchResult(`draw the ${m.object_type} over the grey outline of its anchor`);
  };
  sketchPaper.onerror = () => sketchResult(`the ${m.object_type} canvas could not be shown`, "error");
  sketchPaper.src = m.png;
}
function layoutSketch() {
  // the largest box of the canvas's aspect that fits the view below the tools
  if (!S.sketchCanvas) return;
  const v = view.getBoundingClientRect(), tools = $("sketch-tools").getBoundingClientRect();
  const margin = 10, top = tools.bottom - v.top + margin;
  const aw = Math.max(32, v.width - 2 * margin), ah = Math.max(32, v.height - top - margin);
  const k = Math.min(aw / sketch.width, ah / sketch.height);
  const w = Math.round(sketch.width * k), h = Math.round(sketch.height * k);
  Object.assign(sketch.style, { width: w + "px", height: h + "px",
    left: Math.round(margin + (aw - w) / 2) + "px", top: Math.round(top) + "px" });
}
new ResizeObserver(layoutSketch).observe(view);
new ResizeObserver(layoutSketch).observe($("sketch-tools"));
function canvasPoint(e) { // CSS pixels of the shown canvas -> the canvas's own pixels
  return [e.offsetX * sketch.width / sketch.clientWidth, e.offsetY * sketch.height / sketch.clientHeight];
}
sketch.addEventListener("pointerdown", (e) => {
  drawing = [canvasPoint(e)]; strokes.push(drawing); drawStrokes();
  if ($("sketch-result").className === "error") sketchResult("");
});
sketch.addEventListener("pointermove", (e) => { if (drawing) { drawing.push(canvasPoint(e)); drawStrokes(); } });
window.addEventListener("pointerup", () => { drawing = null; });
$("sketch-clear").onclick = () => { strokes = []; drawStrokes(); sketchResult(""); };
$("sketch-recognize").onclick = () => {
  const c = S.sketchCanvas;
  if (!c) return;
  S.sketchBusy = true; sketchButtons();
  sketchResult(`recognising the ${c.object_type}…`);
  send({ op: "sketch", object_type: c.object_type, strokes, width: c.width, height: c.height, text: S.text });
};
function drawStrokes() {
  const g = sketch.getContext("2d");
  g.clearRect(0, 0, sketch.width, sketch.height);
  if (S.sketchCanvas) g.drawImage(sketchPaper, 0, 0, sketch.width, sketch.height);
  // the pen the server rasterises with: 2 px per 256 px of the canvas
  g.strokeStyle = "#1d1d1d"; g.lineWidth = Math.max(1, 2 * Math.min(sketch.width, sketch.height) / 256);
  g.lineCap = "round"; g.lineJoin = "round";
  for (const s of strokes) {
    g.beginPath(); s.forEach(([x, y], i) => (i ? g.lineTo(x, y) : g.moveTo(x, y)));
    if (s.length === 1) g.lineTo(s[0][0] + 0.01, s[0][1]);
    g.stroke();
  }
}
function onSketchError(m) {
  S.sketchBusy = false; sketchButtons();
  sketchResult(m.message, "error");
}
function onSketch(m) {
  S.sketchBusy = false; sketchButtons();
  sketchResult("");
  const box = $("sketch-result");
  for (const [i, c] of (m.candidates || []).entries()) {
    const b = document.createElement("button");
    b.textContent = `${i + 1}. ${c.snippet} (${Math.round(100 * c.probability)}%) ` +
      Object.entries(c.params || {}).map(([k, v]) => `${k}=${Number(v).toPrecision(3)}`).join(" ");
    if (c.text) b.onclick = () => cm.setValue(c.text);
    else { b.disabled = true; b.title = c.note || ""; }
    box.appendChild(b);
  }
}

// ---------------------------------------------------------------------------------------------
async function main() {
  await defineMode();
  resize();
  new ResizeObserver(resize).observe(view);
  connect();
}
main();
