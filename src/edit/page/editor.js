// The uvpin landmark editor: state, server calls, the constraint list,
// undo/redo. The views are in views.js.
import { MeshView, TextureView } from './views.js';

const $ = (id) => document.getElementById(id);

const app = {
  files: [],
  fileId: null,
  file: null, // the server's state of the file
  mesh: null,
  meshKey: null,
  textureKey: undefined, // the server's key of the texture shown (null: none)
  constraints: [], // [{primitive, vertex, uv: [u, v], label}]
  results: null, // {report, uvs: [Float32Array], coarse?: {level, uvs}} of the last solve or preview
  coarse: null, // the coarse level the server previews a large chart on (its key, mesh, lookups)
  inChart: null,
  selected: null, // {primitive, vertex}
  undo: [],
  redo: [],
  dragStart: null,
  image: null, // the texture, or an image the user loaded
  userImage: false,
  savedHash: null, // what our last save wrote, until the daemon has read it
  saving: false, // a save is on its way
  saveAgain: false, // a change came while a save was pending
  preview: { inFlight: false, pending: false, seq: 0, shown: 0, followUps: 0 },
  warmed: null, // the landmark set the server was last asked to get ready for
  warm: null, // ... once it answered
};

// Turns the 3D view to the landmarks (their mean position), once per mesh.
function faceLandmarks() {
  const sum = [0, 0, 0];
  let n = 0;
  for (const c of app.constraints) {
    const p = app.mesh.primitives.find((q) => q.index === c.primitive);
    if (!p || c.vertex * 3 + 2 >= p.positions.length) continue;
    for (let i = 0; i < 3; i++) sum[i] += p.positions[c.vertex * 3 + i];
    n += 1;
  }
  if (n) meshView.face(sum.map((x) => x / n));
}

// Measurements the drag benchmark and the browser test read.
window.uvpinEditor = {
  latencies: [], // ms from a pointer move to the redraw of its solve
  previews: 0,
  saves: 0,
  state: () => ({ constraints: app.constraints, selected: app.selected, fileState: app.file && app.file.state }),
  // The 3D view's camera: its up axis and where its eye is.
  camera: () => ({ up: meshView.camera.up, eye: meshView.eye(), target: meshView.camera.target }),
  // Where a vertex is in the layout shown (glTF texture coordinates).
  uvOf: (vertex, primitive = 0) => {
    const k = app.mesh ? app.mesh.primitives.findIndex((p) => p.index === primitive) : -1;
    const coarse = app.results && app.results.coarse;
    const i = coarse ? coarse.level.index.get(`${k}:${vertex}`) : undefined;
    if (i !== undefined) return [coarse.uvs[i * 2], coarse.uvs[i * 2 + 1]];
    const uvs = app.results && app.results.uvs && k >= 0 ? app.results.uvs[k] : null;
    return uvs ? [uvs[vertex * 2], uvs[vertex * 2 + 1]] : null;
  },
  // Whether the server is ready for a drag of the current landmarks.
  dragReady: () => app.warm !== null && app.warm === app.warmed,
  // Vertices of the coarse level the layout is shown on (0: the chart itself).
  shownLevel: () => (app.results && app.results.coarse ? app.results.coarse.level.positions.length / 3 : 0),
  // A texture coordinate's position in the texture view (CSS pixels).
  textureToScreen: (uv) => textureView.toScreen(uv),
};

let meshView;
let textureView;

function primitiveOf(c) {
  return c.primitive ?? (app.file ? app.file.primitive : 0);
}

function sameVertex(a, b) {
  return a && b && a.vertex === b.vertex && primitiveOf(a) === primitiveOf(b);
}

function setStatus(state, text) {
  const s = $('status');
  s.dataset.state = state;
  s.textContent = `${state}${text ? ` — ${text}` : ''}`;
  s.title = s.textContent;
}

async function getJson(url) {
  const r = await fetch(url, { cache: 'no-store' });
  const body = await r.json().catch(() => ({}));
  if (!r.ok) throw new Error(body.error || `${r.status} ${r.statusText}`);
  return body;
}

async function postJson(url, value) {
  const r = await fetch(url, { method: 'POST', headers: { 'Content-Type': 'application/json' }, body: JSON.stringify(value) });
  const body = await r.json().catch(() => ({}));
  return { ok: r.ok, status: r.status, body };
}

// ---- loading ----

async function loadFiles() {
  const { files } = await getJson('/api/files');
  app.files = files;
  const select = $('file');
  select.replaceChildren(...files.map((f) => {
    const o = document.createElement('option');
    o.value = String(f.id);
    o.textContent = f.name;
    return o;
  }));
  if (app.fileId === null && files.length) {
    const wanted = new URLSearchParams(location.search).get('file');
    const chosen = files.find((f) => f.name === wanted) || files[0];
    await openFile(chosen.id);
  }
  if (app.fileId !== null) select.value = String(app.fileId);
  if (!files.length) setStatus('solving', 'waiting for the daemon to find a constraint file');
}

async function openFile(id) {
  app.fileId = id;
  app.file = null;
  app.savedHash = null;
  app.saveAgain = false;
  app.dragStart = null;
  app.meshKey = null;
  app.textureKey = undefined;
  app.undo = [];
  app.redo = [];
  app.selected = null;
  app.userImage = false;
  await refreshFile();
}

function uvArrays(uvs) {
  return uvs.map((u) => new Float32Array(u));
}

// A coarse level as the server sends it once: each vertex as (primitive
// position, vertex) of the mesh, its triangles. Positions are looked up
// here; `index` finds a mesh vertex's coarse vertex.
function coarseLevel(key, sent) {
  const n = sent.vertices.length / 2;
  const positions = new Float32Array(n * 3);
  const index = new Map();
  const primitives = new Set();
  for (let i = 0; i < n; i++) {
    const k = sent.vertices[i * 2];
    const v = sent.vertices[i * 2 + 1];
    const from = app.mesh.primitives[k].positions;
    positions[i * 3] = from[v * 3];
    positions[i * 3 + 1] = from[v * 3 + 1];
    positions[i * 3 + 2] = from[v * 3 + 2];
    index.set(`${k}:${v}`, i);
    primitives.add(k);
  }
  return { key, positions, indices: new Uint32Array(sent.indices), index, primitives };
}

// A preview's layout: the chart's UVs, or its coarse level's (the level
// kept while its key holds). The chart's last UVs stay for the rest.
function previewResults(body) {
  if (!body.coarse) return { report: body.report, uvs: uvArrays(body.uvs), from: 'preview' };
  const c = body.coarse;
  if (c.mesh) app.coarse = coarseLevel(c.key, c.mesh);
  if (!app.coarse || app.coarse.key !== c.key) return null;
  const uvs = app.results ? app.results.uvs : null;
  return { report: body.report, uvs, coarse: { level: app.coarse, uvs: new Float32Array(c.uvs) }, from: 'preview' };
}

async function refreshFile() {
  const id = app.fileId;
  const file = await getJson(`/api/file/${id}`);
  // An answer to an older request, or about another file: nothing to do.
  if (id !== app.fileId || (app.file && file.version < app.file.version)) return;
  app.file = file;
  // The daemon has read our last save: a save waiting on it may go now.
  const caughtUp = app.savedHash !== null && file.hash === app.savedHash;
  if (caughtUp) app.savedHash = null;
  if (file.asset && file.asset !== app.meshKey) {
    const mesh = await getJson(`/api/file/${app.fileId}/mesh`);
    // A newer state came while the mesh loaded: it has drawn what is
    // current (the mesh with its solved UVs); this older one would draw
    // the mesh anew without them.
    if (app.file !== file) return;
    app.mesh = mesh;
    app.meshKey = file.asset;
    app.coarse = null;
    meshView.setMesh(app.mesh);
    textureView.setMesh(app.mesh);
    app.faceLandmarks = true;
  }
  // A new mesh, another image: named, repainted: the texture anew.
  if (file.asset && file.texture !== app.textureKey) {
    app.textureKey = file.texture;
    if (!app.userImage) loadTexture(file.texture);
  }
  // The page's own list stays while it is ahead of the file (saves pending).
  const ahead = app.savedHash !== null || app.saveAgain;
  if (!app.dragStart && !ahead) {
    app.constraints = file.constraints.map((c) => ({ primitive: c.primitive, vertex: c.vertex, uv: c.target, label: c.label }));
  }
  if (app.faceLandmarks && app.constraints.length) {
    app.faceLandmarks = false;
    faceLandmarks();
  }
  if (file.solved && !app.dragStart && !app.preview.inFlight && !ahead) {
    app.inChart = file.solved.in_chart;
    app.written = uvArrays(file.solved.written);
    app.results = { report: file.solved.report, uvs: uvArrays(file.solved.uvs), from: 'file' };
    warmPreviews();
  }
  showStatus();
  redraw({ layout: true });
  if (app.savedHash === null && app.saveAgain) {
    app.saveAgain = false;
    save();
  }
}

function loadTexture(key) {
  if (!key) {
    app.image = null;
    meshView.setImage(null);
    textureView.setImage(null);
    return;
  }
  const img = new Image();
  app.textureLoading = key;
  // Either way the views are drawn anew, and the page may then be ready.
  const settle = () => {
    if (app.textureLoading === key) app.textureLoading = null;
    redraw({ list: false });
  };
  img.onload = () => {
    if (app.userImage) return settle();
    app.image = img;
    meshView.setImage(img);
    textureView.setImage(img);
    settle();
  };
  img.onerror = () => {
    app.image = null;
    meshView.setImage(null);
    textureView.setImage(null);
    settle();
  };
  img.src = `/api/file/${app.fileId}/texture?key=${encodeURIComponent(key)}`;
}

function showStatus() {
  const f = app.file;
  if (!f) return;
  if (f.state === 'error') {
    setStatus('error', f.error || 'the file has an error');
    return;
  }
  if (f.state === 'solving') {
    setStatus('solving', f.name);
    return;
  }
  const r = app.results && app.results.report;
  if (!r) {
    setStatus(f.state, f.name);
    return;
  }
  const reached = r.constraints.filter((c) => c.reached).length;
  const state = app.results.from === 'preview' ? (r.status === 'reached' ? 'reached' : 'partial') : f.state;
  const words = `${reached} of ${r.constraints.length} on target, max residual ${r.max_residual.toExponential(1)}, ` +
    `stretch ${r.stretch_l2.toFixed(3)}, ${r.total_ms.toFixed(0)} ms` +
    (app.results.from !== 'preview' ? '' : app.results.coarse ? ' (preview on a coarse level)' : ' (preview)') + (r.message && state !== 'reached' ? ` — ${r.message}` : '');
  setStatus(state, words);
}

// ---- drawing ----

function resultOf(c) {
  const r = app.results && app.results.report;
  if (!r) return null;
  return r.constraints.find((x) => x.vertex === c.vertex && x.primitive === primitiveOf(c)) || null;
}

// What the next frame must redraw; frames coalesce any number of changes.
const dirty = { layout: false, list: false };
let frameRequested = false;

// Schedules a redraw at the next frame, or at once with `now` (a preview's
// answer: the drag's redraw does not wait for a frame): the markers always,
// the layout when a new solve came (`layout`), the list unless a drag is
// running (`list`).
function redraw({ layout = false, list = true, now = false } = {}) {
  dirty.layout ||= layout;
  dirty.list ||= list;
  if (now) {
    render();
    return;
  }
  // Something changed since the last frame: not ready until it is painted.
  $('mesh-view').dataset.ready = 'false';
  if (!frameRequested) {
    frameRequested = true;
    requestAnimationFrame(render);
  }
}

function render() {
  frameRequested = false;
  const markers = app.constraints.map((c, k) => {
    const r = resultOf(c);
    return {
      number: k + 1,
      primitive: primitiveOf(c),
      vertex: c.vertex,
      label: c.label,
      target: c.uv,
      result: r ? r.result : null,
      reached: r ? r.reached : undefined,
      residual: r ? r.residual : 0,
      selected: sameVertex(c, app.selected),
      index: k,
    };
  });
  if (dirty.layout && app.results) {
    meshView.setUvs(app.results.uvs, app.results.coarse);
    textureView.setLayout(app.results.uvs, app.inChart, app.results.coarse, app.written);
  }
  meshView.setMarkers(markers, app.selected);
  textureView.setMarkers(markers);
  if (dirty.list && !app.dragStart) {
    renderList();
    dirty.list = false;
  }
  dirty.layout = false;
  $('undo').disabled = !app.undo.length;
  $('redo').disabled = !app.redo.length;
  const sel = app.selected;
  $('selection').textContent = sel
    ? `Selected: vertex ${sel.vertex}${app.mesh && app.mesh.primitives.length > 1 ? ` (primitive ${sel.primitive})` : ''}. Click the texture to place its target.`
    : 'No vertex selected: click the mesh.';
  if (app.drawnMove !== undefined) {
    window.uvpinEditor.latencies.push(performance.now() - app.drawnMove);
    app.drawnMove = undefined;
  }
  markReady();
}

// `data-ready` on the mesh view: "true" once this frame has painted the
// file's mesh through its latest solved UVs with its texture settled (loaded
// or failed), so a reader of the canvas (the browser test, a screenshot)
// waits for the picture itself rather than for the status text.
function markReady() {
  const f = app.file;
  const ready = Boolean(f && f.state !== 'solving' && app.mesh && app.meshKey === f.asset &&
    app.results && app.textureLoading == null && !frameRequested);
  const view = $('mesh-view');
  view.dataset.ready = String(ready);
  view.dataset.drawnHash = ready ? String(f.hash) : '';
}

function renderList() {
  const list = $('constraint-list');
  const active = document.activeElement;
  const editing = active && active.dataset && active.dataset.testid === 'constraint-label' ? Number(active.dataset.index) : -1;
  const items = app.constraints.map((c, k) => {
    const r = resultOf(c);
    const li = document.createElement('li');
    li.className = 'constraint' + (sameVertex(c, app.selected) ? ' selected' : '');
    li.dataset.testid = 'constraint';
    li.setAttribute('data-testid', 'constraint');
    li.dataset.vertex = String(c.vertex);
    li.dataset.reached = r ? String(r.reached) : 'unknown';
    const number = document.createElement('span');
    number.className = 'number';
    number.textContent = String(k + 1);
    const label = document.createElement('input');
    label.type = 'text';
    label.placeholder = 'label';
    label.value = c.label || '';
    label.setAttribute('data-testid', 'constraint-label');
    label.dataset.index = String(k);
    label.addEventListener('change', () => edit((list) => { list[k].label = label.value.trim() || null; }));
    label.addEventListener('click', (e) => e.stopPropagation());
    const del = document.createElement('button');
    del.textContent = '✕';
    del.title = 'Delete this constraint';
    del.setAttribute('data-testid', 'constraint-delete');
    del.addEventListener('click', (e) => {
      e.stopPropagation();
      edit((list) => { list.splice(k, 1); });
    });
    const detail = document.createElement('span');
    detail.className = 'detail';
    const residual = r ? `residual ${r.residual.toExponential(1)}` : 'not solved yet';
    detail.innerHTML = '';
    detail.append(`vertex ${c.vertex} → (${c.uv[0].toFixed(4)}, ${c.uv[1].toFixed(4)}) · `);
    const res = document.createElement('span');
    res.setAttribute('data-testid', 'constraint-residual');
    res.className = r && !r.reached ? 'bad' : '';
    res.textContent = `${residual} · ${r ? (r.reached ? 'reached' : 'not reached') : ''}`;
    detail.append(res);
    li.append(number, label, del, detail);
    li.addEventListener('click', () => {
      app.selected = { primitive: primitiveOf(c), vertex: c.vertex };
      redraw();
    });
    return li;
  });
  list.replaceChildren(...items);
  if (editing >= 0) {
    const again = list.querySelector(`input[data-index="${editing}"]`);
    if (again) again.focus();
  }
}

// ---- editing ----

function snapshot() {
  return JSON.parse(JSON.stringify(app.constraints));
}

// Applies `change` to a copy of the list, with undo, then previews and saves.
function edit(change) {
  if (!app.file || !app.file.editable) {
    setStatus('error', 'the file cannot be edited until its current content loads (fix its error first)');
    return;
  }
  const before = snapshot();
  const list = snapshot();
  change(list);
  app.undo.push(before);
  app.redo = [];
  app.constraints = list;
  redraw();
  requestPreview();
  save();
}

function restore(from, to) {
  if (!from.length) return;
  to.push(snapshot());
  app.constraints = from.pop();
  redraw();
  requestPreview();
  save();
}

function place(uv) {
  const sel = app.selected;
  if (!sel) {
    setStatus(app.file ? app.file.state : 'solving', 'select a vertex on the mesh first');
    return;
  }
  edit((list) => {
    const k = list.findIndex((c) => sameVertex(c, sel));
    if (k >= 0) list[k].uv = uv;
    else list.push({ primitive: sel.primitive, vertex: sel.vertex, uv, label: null });
  });
}

function wantedList() {
  return app.constraints.map((c) => ({ primitive: primitiveOf(c), vertex: c.vertex, uv: c.uv, label: c.label || null }));
}

// One save at a time, each on the file the daemon has read: a save made
// while one is on its way, or before the daemon has read the last one, is
// sent once that has happened (with the list as it is then).
async function save() {
  if (!app.file) return;
  if (app.saving || app.savedHash) {
    app.saveAgain = true;
    return;
  }
  app.saving = true;
  const id = app.fileId;
  const r = await postJson(`/api/file/${id}/save`, { base: app.file.hash, constraints: wantedList() });
  app.saving = false;
  if (id !== app.fileId) return;
  if (r.ok) {
    window.uvpinEditor.saves += 1;
    if (r.body.unchanged) {
      // The file already says this: nothing for the daemon to read.
      if (app.saveAgain) {
        app.saveAgain = false;
        save();
      }
      return;
    }
    app.savedHash = r.body.hash;
    setStatus('solving', 'saved; the daemon is solving');
  } else {
    setStatus('error', r.body.error || `save failed (${r.status})`);
    app.savedHash = null;
    app.saveAgain = false;
    if (r.status === 409) await refreshFile();
  }
}

// Asks for a preview of the page's list (numbered `seq`), naming the coarse
// level the page holds (its mesh is not sent again); null if unanswered.
function postPreview(seq) {
  const held = app.coarse ? app.coarse.key : null;
  return postJson(`/api/file/${app.fileId}/preview`, { seq, constraints: wantedList(), coarse_key: held }).catch(() => null);
}

// Asks the server to get ready for a drag of the current landmarks (a large
// chart's coarse level is made once per landmark set, in about a second at
// 400k vertices), so the first move does not wait for it. The answer is
// not shown; its coarse level's mesh is kept.
async function warmPreviews() {
  const key = `${app.meshKey} ${app.constraints.map((c) => `${primitiveOf(c)}:${c.vertex}`).sort().join(',')}`;
  if (app.warmed === key || !app.file || !app.file.editable) return;
  app.warmed = key;
  app.warm = null;
  const r = await postPreview(0);
  const c = r && r.ok && r.body.coarse;
  if (c && c.mesh && app.mesh && key.startsWith(`${app.meshKey} `)) app.coarse = coarseLevel(c.key, c.mesh);
  if (app.warmed === key) app.warm = key;
}

async function requestPreview(moveTime) {
  const p = app.preview;
  p.seq += 1;
  if (moveTime !== undefined) {
    p.moves = p.moves || new Map();
    p.moves.set(p.seq, moveTime);
    p.followUps = 0;
  }
  if (p.inFlight) {
    p.pending = true;
    return;
  }
  p.inFlight = true;
  const seq = p.seq;
  const r = await postPreview(seq);
  p.inFlight = false;
  const results = r && r.ok && r.body.report && seq > p.shown ? previewResults(r.body) : null;
  if (results) {
    p.shown = seq;
    app.results = results;
    window.uvpinEditor.previews += 1;
    showStatus();
    const moved = p.moves && p.moves.get(seq);
    if (moved !== undefined) {
      app.drawnMove = moved;
      p.moves.clear();
    }
    redraw({ layout: true, list: !app.dragStart, now: true });
  } else if (r && r.ok && r.body.invalid) {
    setStatus('error', r.body.invalid);
  }
  if (p.pending) {
    p.pending = false;
    requestPreview(p.moves && p.moves.size ? Math.min(...p.moves.values()) : undefined);
  } else if (results && results.coarse && results.report.status !== 'reached' && app.dragStart && p.followUps < 4) {
    // The coarse level stopped short within its time and the pointer rests:
    // the solve goes on from where it stopped.
    p.followUps += 1;
    requestPreview();
  }
}

// ---- wiring ----

function onPick(picked) {
  app.selected = picked;
  redraw();
}

const textureHandlers = {
  onPlace: place,
  onDragStart(marker) {
    app.selected = { primitive: marker.primitive, vertex: marker.vertex };
    app.dragStart = snapshot();
    redraw();
  },
  onDrag(marker, uv, timeStamp) {
    const c = app.constraints[marker.index];
    if (!c) return;
    c.uv = uv;
    redraw({ list: false });
    const now = performance.now();
    requestPreview(Math.min(now, timeStamp || now));
  },
  onDragEnd(marker, moved) {
    const before = app.dragStart;
    app.dragStart = null;
    if (!moved || !before || !app.file || !app.file.editable) {
      if (before && moved) app.constraints = before;
      redraw({ layout: true });
      return;
    }
    app.undo.push(before);
    app.redo = [];
    save();
    redraw();
  },
};

function listenKeys() {
  window.addEventListener('keydown', (e) => {
    const typing = e.target && e.target.tagName === 'INPUT';
    const mod = e.ctrlKey || e.metaKey;
    if (mod && !typing && e.key.toLowerCase() === 'z') {
      e.preventDefault();
      if (e.shiftKey) restore(app.redo, app.undo);
      else restore(app.undo, app.redo);
    } else if (mod && !typing && e.key.toLowerCase() === 'y') {
      e.preventDefault();
      restore(app.redo, app.undo);
    } else if ((e.key === 'Delete' || e.key === 'Backspace') && !typing && app.selected) {
      const k = app.constraints.findIndex((c) => sameVertex(c, app.selected));
      if (k >= 0) edit((list) => { list.splice(k, 1); });
    } else if (e.key === 'Escape') {
      app.selected = null;
      redraw();
    }
  });
}

function listenEvents() {
  const events = new EventSource('/api/events');
  events.addEventListener('files', async (e) => {
    const data = JSON.parse(e.data);
    const known = new Set(app.files.map((f) => f.id));
    if (data.files.some((f) => !known.has(f.id)) || !app.files.length) {
      await loadFiles();
    }
    app.files = data.files;
    const mine = data.files.find((f) => f.id === app.fileId);
    if (mine && (!app.file || mine.version !== app.file.version)) await refreshFile();
  });
  events.onerror = () => {
    if (events.readyState === EventSource.CLOSED) setStatus('error', 'the daemon stopped; reload the page when it runs again');
  };
}

function start() {
  try {
    meshView = new MeshView($('mesh-view'), $('mesh-overlay'), $('hover'), { onPick });
  } catch (e) {
    setStatus('error', `${e.message}`);
    return;
  }
  textureView = new TextureView($('texture-view'), textureHandlers);
  $('file').addEventListener('change', (e) => openFile(Number(e.target.value)));
  $('undo').addEventListener('click', () => restore(app.undo, app.redo));
  $('redo').addEventListener('click', () => restore(app.redo, app.undo));
  $('image-input').addEventListener('change', (e) => {
    const file = e.target.files && e.target.files[0];
    if (!file) return;
    const img = new Image();
    img.onload = () => {
      app.userImage = true;
      app.image = img;
      meshView.setImage(img);
      textureView.setImage(img);
    };
    img.src = URL.createObjectURL(file);
  });
  listenKeys();
  listenEvents();
  loadFiles().catch((e) => setStatus('error', e.message));
}

start();
