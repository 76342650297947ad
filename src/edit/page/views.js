// The editor's two views: the mesh (WebGL2, shaded and textured through the
// current UVs) and the texture (Canvas 2D, the layout over the image).

const VERTEX_SHADER = `#version 300 es
in vec3 position;
in vec2 uv;
uniform mat4 viewProjection;
uniform mat4 view;
out vec3 viewPosition;
out vec2 vUv;
void main() {
  vUv = uv;
  viewPosition = (view * vec4(position, 1.0)).xyz;
  gl_Position = viewProjection * vec4(position, 1.0);
}`;

const FRAGMENT_SHADER = `#version 300 es
precision highp float;
in vec3 viewPosition;
in vec2 vUv;
uniform sampler2D image;
uniform bool hasImage;
out vec4 color;
void main() {
  vec3 normal = normalize(cross(dFdx(viewPosition), dFdy(viewPosition)));
  float light = 0.35 + 0.65 * abs(normal.z);
  vec3 base;
  if (hasImage) {
    base = texture(image, vUv).rgb;
  } else {
    vec2 cell = floor(vUv * 16.0);
    float checker = mod(cell.x + cell.y, 2.0);
    base = mix(vec3(0.85, 0.86, 0.9), vec3(0.25, 0.45, 0.85), checker);
  }
  color = vec4(base * light, 1.0);
}`;

// 4 × 4 matrices, column-major.
function perspective(fovy, aspect, near, far) {
  const f = 1 / Math.tan(fovy / 2);
  const nf = 1 / (near - far);
  return [f / aspect, 0, 0, 0, 0, f, 0, 0, 0, 0, (far + near) * nf, -1, 0, 0, 2 * far * near * nf, 0];
}

function multiply(a, b) {
  const out = new Array(16).fill(0);
  for (let c = 0; c < 4; c++) {
    for (let r = 0; r < 4; r++) {
      let s = 0;
      for (let k = 0; k < 4; k++) s += a[k * 4 + r] * b[c * 4 + k];
      out[c * 4 + r] = s;
    }
  }
  return out;
}

function sub(a, b) { return [a[0] - b[0], a[1] - b[1], a[2] - b[2]]; }
function dot(a, b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
function cross(a, b) { return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]; }
function scale(a, s) { return [a[0] * s, a[1] * s, a[2] * s]; }
function add(a, b) { return [a[0] + b[0], a[1] + b[1], a[2] + b[2]]; }
function normalize(a) { const l = Math.hypot(a[0], a[1], a[2]) || 1; return scale(a, 1 / l); }

function compile(gl, type, source) {
  const shader = gl.createShader(type);
  gl.shaderSource(shader, source);
  gl.compileShader(shader);
  if (!gl.getShaderParameter(shader, gl.COMPILE_STATUS)) {
    throw new Error(gl.getShaderInfoLog(shader));
  }
  return shader;
}

// A 2D colour for a stretch value (1 = isometry).
export function stretchColour(s) {
  const c = stretchRgb(s);
  return `rgb(${c[0]},${c[1]},${c[2]})`;
}

function stretchRgb(s) {
  const t = Math.max(0, Math.min(1, Math.log2(Math.max(s, 1)) / 2));
  const stops = [[62, 207, 110], [240, 210, 60], [255, 90, 82]];
  const k = t < 0.5 ? 0 : 1;
  const f = t < 0.5 ? t * 2 : (t - 0.5) * 2;
  return stops[k].map((v, i) => Math.round(v + (stops[k + 1][i] - v) * f));
}

// Layouts of more triangles than this are drawn pixel by pixel: a canvas
// path of millions of edges takes minutes to stroke, and at that density
// the edges are pixels anyway.
const RASTER_ABOVE = 60000;

// Draws the edges of `tris` ({pts, s}: CSS-pixel corners, stretch) onto
// `ctx`, one pixel wide, coloured by stretch times `norm`.
function rasterEdges(ctx, tris, norm) {
  const dpr = window.devicePixelRatio || 1;
  const w = ctx.canvas.width;
  const h = ctx.canvas.height;
  const image = new ImageData(w, h);
  const px = new Uint32Array(image.data.buffer);
  const plot = (a, b, colour) => {
    const [x0, y0, x1, y1] = [a[0] * dpr, a[1] * dpr, b[0] * dpr, b[1] * dpr];
    const n = Math.max(1, Math.ceil(Math.max(Math.abs(x1 - x0), Math.abs(y1 - y0))));
    for (let i = 0; i <= n; i++) {
      const x = Math.round(x0 + ((x1 - x0) * i) / n);
      const y = Math.round(y0 + ((y1 - y0) * i) / n);
      if (x >= 0 && y >= 0 && x < w && y < h) px[y * w + x] = colour;
    }
  };
  for (const { pts, s } of tris) {
    const [r, g, b] = stretchRgb(Number.isFinite(s.l2) ? s.l2 * norm : Infinity);
    const colour = ((255 << 24) | (b << 16) | (g << 8) | r) >>> 0;
    plot(pts[0], pts[1], colour);
    plot(pts[1], pts[2], colour);
    plot(pts[2], pts[0], colour);
  }
  const edges = document.createElement('canvas');
  edges.width = w;
  edges.height = h;
  edges.getContext('2d', { willReadFrequently: true }).putImageData(image, 0, 0);
  ctx.save();
  ctx.setTransform(1, 0, 0, 1, 0, 0);
  ctx.drawImage(edges, 0, 0);
  ctx.restore();
}

// Whether WebGL draws in software (SwiftShader or llvmpipe, no GPU): there
// multisampling costs a full-canvas resolve on every frame, which halved
// the redraws while dragging on a large mesh, so edges are left aliased.
function softwareRenderer() {
  const gl = document.createElement('canvas').getContext('webgl2');
  const info = gl && gl.getExtension('WEBGL_debug_renderer_info');
  const name = info ? String(gl.getParameter(info.UNMASKED_RENDERER_WEBGL)) : '';
  if (gl) gl.getExtension('WEBGL_lose_context')?.loseContext();
  return /swiftshader|llvmpipe|software/i.test(name);
}

export class MeshView {
  constructor(canvas, overlay, hover, handlers) {
    this.canvas = canvas;
    this.overlay = overlay;
    this.hover = hover;
    this.handlers = handlers;
    this.gl = canvas.getContext('webgl2', { antialias: !softwareRenderer(), preserveDrawingBuffer: true });
    if (!this.gl) throw new Error('WebGL2 is not available in this browser');
    const gl = this.gl;
    this.program = gl.createProgram();
    gl.attachShader(this.program, compile(gl, gl.VERTEX_SHADER, VERTEX_SHADER));
    gl.attachShader(this.program, compile(gl, gl.FRAGMENT_SHADER, FRAGMENT_SHADER));
    gl.linkProgram(this.program);
    if (!gl.getProgramParameter(this.program, gl.LINK_STATUS)) throw new Error(gl.getProgramInfoLog(this.program));
    this.uniforms = {};
    for (const name of ['viewProjection', 'view', 'image', 'hasImage']) {
      this.uniforms[name] = gl.getUniformLocation(this.program, name);
    }
    this.texture = null;
    this.primitives = [];
    this.camera = { yaw: 0, pitch: 0, distance: 3, target: [0, 0, 0], radius: 1, up: [0, 1, 0] };
    this.markers = [];
    this.selected = null;
    this.listen();
  }

  setMesh(mesh) {
    const gl = this.gl;
    for (const p of this.primitives) {
      gl.deleteVertexArray(p.vao);
      gl.deleteBuffer(p.positionBuffer);
      gl.deleteBuffer(p.uvBuffer);
      gl.deleteBuffer(p.indexBuffer);
    }
    this.coarse = null;
    this.primitives = mesh.primitives.map((p) => {
      const positions = new Float32Array(p.positions);
      const indices = new Uint32Array(p.indices);
      return { index: p.index, positions, indices, ...this.buffers(positions, indices) };
    });
    const b = mesh.bounds || { min: [-1, -1, -1], max: [1, 1, 1] };
    this.camera.target = scale(add(b.min, b.max), 0.5);
    this.camera.radius = Math.max(1e-9, Math.hypot(...sub(b.max, b.min)) / 2);
    this.camera.distance = this.camera.radius * 2.6;
    this.camera.up = mesh.up || [0, 1, 0];
    this.camera.yaw = 0;
    this.camera.pitch = 0;
    this.draw();
  }

  // Turns the camera round the up axis to look at `point` (mesh
  // coordinates) from outside: the side the landmarks are on.
  face(point) {
    const c = this.camera;
    const [f0, s0] = this.ground();
    const d = sub(point, c.target);
    const x = dot(d, s0);
    const z = dot(d, f0);
    if (Math.hypot(x, z) < 1e-9 * c.radius) return;
    c.yaw = Math.atan2(x, z);
    c.pitch = 0;
    this.draw();
  }

  // Two directions across the up axis: yaw 0 looks from the first.
  ground() {
    const up = this.camera.up;
    const seed = Math.abs(up[2]) < 0.9 ? [0, 0, 1] : [0, -1, 0];
    const f0 = normalize(sub(seed, scale(up, dot(seed, up))));
    return [f0, cross(up, f0)];
  }

  // A vertex array of `positions` and `indices`, with an empty UV buffer.
  buffers(positions, indices) {
    const gl = this.gl;
    const vao = gl.createVertexArray();
    gl.bindVertexArray(vao);
    const positionBuffer = gl.createBuffer();
    gl.bindBuffer(gl.ARRAY_BUFFER, positionBuffer);
    gl.bufferData(gl.ARRAY_BUFFER, positions, gl.STATIC_DRAW);
    const positionAt = gl.getAttribLocation(this.program, 'position');
    gl.enableVertexAttribArray(positionAt);
    gl.vertexAttribPointer(positionAt, 3, gl.FLOAT, false, 0, 0);
    const uvBuffer = gl.createBuffer();
    gl.bindBuffer(gl.ARRAY_BUFFER, uvBuffer);
    gl.bufferData(gl.ARRAY_BUFFER, new Float32Array(positions.length / 3 * 2), gl.DYNAMIC_DRAW);
    const uvAt = gl.getAttribLocation(this.program, 'uv');
    gl.enableVertexAttribArray(uvAt);
    gl.vertexAttribPointer(uvAt, 2, gl.FLOAT, false, 0, 0);
    const indexBuffer = gl.createBuffer();
    gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, indexBuffer);
    gl.bufferData(gl.ELEMENT_ARRAY_BUFFER, indices, gl.STATIC_DRAW);
    gl.bindVertexArray(null);
    return { vao, positionBuffer, uvBuffer, indexBuffer };
  }

  // The chart's UVs per primitive; or, with `coarse` ({level, uvs}), its
  // coarse level drawn in place of the primitives it covers (the others
  // keep the UVs they had).
  setUvs(uvs, coarse) {
    const gl = this.gl;
    if (coarse) {
      this.setCoarse(coarse);
      this.draw();
      return;
    }
    this.coarse = null;
    this.primitives.forEach((p, k) => {
      const data = uvs && uvs[k] && uvs[k].length === p.positions.length / 3 * 2 ? uvs[k] : null;
      gl.bindBuffer(gl.ARRAY_BUFFER, p.uvBuffer);
      gl.bufferData(gl.ARRAY_BUFFER, data || new Float32Array(p.positions.length / 3 * 2), gl.DYNAMIC_DRAW);
    });
    this.draw();
  }

  setCoarse({ level, uvs }) {
    const gl = this.gl;
    let c = this.coarseBuffers;
    if (!c || c.key !== level.key) {
      if (c) {
        gl.deleteVertexArray(c.vao);
        [c.positionBuffer, c.uvBuffer, c.indexBuffer].forEach((b) => gl.deleteBuffer(b));
      }
      c = this.coarseBuffers = { key: level.key, count: level.indices.length, ...this.buffers(level.positions, level.indices) };
    }
    gl.bindBuffer(gl.ARRAY_BUFFER, c.uvBuffer);
    gl.bufferData(gl.ARRAY_BUFFER, uvs, gl.DYNAMIC_DRAW);
    this.coarse = { level, buffers: c };
  }

  setImage(image) {
    const gl = this.gl;
    if (this.texture) gl.deleteTexture(this.texture);
    this.texture = null;
    if (image) {
      this.texture = gl.createTexture();
      gl.bindTexture(gl.TEXTURE_2D, this.texture);
      gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA, gl.RGBA, gl.UNSIGNED_BYTE, image);
      gl.generateMipmap(gl.TEXTURE_2D);
      gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.LINEAR_MIPMAP_LINEAR);
      gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_S, gl.CLAMP_TO_EDGE);
      gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_T, gl.CLAMP_TO_EDGE);
    }
    this.draw();
  }

  // Markers: [{number, primitive, vertex, reached}]; the selected vertex.
  setMarkers(markers, selected) {
    this.markers = markers;
    this.selected = selected;
    this.drawOverlay();
  }

  eye() {
    const c = this.camera;
    const [f0, s0] = this.ground();
    const across = add(scale(f0, Math.cos(c.yaw)), scale(s0, Math.sin(c.yaw)));
    const dir = add(scale(across, Math.cos(c.pitch)), scale(c.up, Math.sin(c.pitch)));
    return add(c.target, scale(dir, c.distance));
  }

  matrices() {
    const w = this.canvas.width;
    const h = this.canvas.height;
    const eye = this.eye();
    const forward = normalize(sub(this.camera.target, eye));
    const right = normalize(cross(forward, this.camera.up));
    const up = cross(right, forward);
    const view = [
      right[0], up[0], -forward[0], 0,
      right[1], up[1], -forward[1], 0,
      right[2], up[2], -forward[2], 0,
      -dot(right, eye), -dot(up, eye), dot(forward, eye), 1,
    ];
    const r = this.camera.radius;
    const projection = perspective(Math.PI / 4, w / Math.max(h, 1), this.camera.distance * 0.01 + r * 1e-4, this.camera.distance + 4 * r);
    return { view, viewProjection: multiply(projection, view), eye, forward, right, up, aspect: w / Math.max(h, 1) };
  }

  resize() {
    const dpr = window.devicePixelRatio || 1;
    for (const c of [this.canvas, this.overlay]) {
      const w = Math.max(1, Math.round(c.clientWidth * dpr));
      const h = Math.max(1, Math.round(c.clientHeight * dpr));
      if (c.width !== w || c.height !== h) {
        c.width = w;
        c.height = h;
      }
    }
  }

  draw() {
    this.resize();
    const gl = this.gl;
    gl.viewport(0, 0, this.canvas.width, this.canvas.height);
    gl.clearColor(0.11, 0.12, 0.14, 1);
    gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    gl.enable(gl.DEPTH_TEST);
    gl.useProgram(this.program);
    const m = this.matrices();
    gl.uniformMatrix4fv(this.uniforms.viewProjection, false, m.viewProjection);
    gl.uniformMatrix4fv(this.uniforms.view, false, m.view);
    gl.uniform1i(this.uniforms.hasImage, this.texture ? 1 : 0);
    gl.activeTexture(gl.TEXTURE0);
    gl.bindTexture(gl.TEXTURE_2D, this.texture);
    gl.uniform1i(this.uniforms.image, 0);
    const coarse = this.coarse;
    this.primitives.forEach((p, k) => {
      if (coarse && coarse.level.primitives.has(k)) return;
      gl.bindVertexArray(p.vao);
      gl.drawElements(gl.TRIANGLES, p.indices.length, gl.UNSIGNED_INT, 0);
    });
    if (coarse) {
      gl.bindVertexArray(coarse.buffers.vao);
      gl.drawElements(gl.TRIANGLES, coarse.buffers.count, gl.UNSIGNED_INT, 0);
    }
    gl.bindVertexArray(null);
    this.drawOverlay();
  }

  // Screen position (CSS pixels) of a mesh point, or null behind the camera.
  project(point, m = this.matrices()) {
    const v = m.viewProjection;
    const x = v[0] * point[0] + v[4] * point[1] + v[8] * point[2] + v[12];
    const y = v[1] * point[0] + v[5] * point[1] + v[9] * point[2] + v[13];
    const w = v[3] * point[0] + v[7] * point[1] + v[11] * point[2] + v[15];
    if (w <= 0) return null;
    return [(x / w * 0.5 + 0.5) * this.canvas.clientWidth, (0.5 - y / w * 0.5) * this.canvas.clientHeight];
  }

  position(primitive, vertex) {
    const p = this.primitives.find((q) => q.index === primitive);
    if (!p || vertex * 3 + 2 >= p.positions.length) return null;
    return [p.positions[vertex * 3], p.positions[vertex * 3 + 1], p.positions[vertex * 3 + 2]];
  }

  drawOverlay() {
    const ctx = this.overlay.getContext('2d', { willReadFrequently: true });
    const dpr = window.devicePixelRatio || 1;
    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
    ctx.clearRect(0, 0, this.overlay.width, this.overlay.height);
    const m = this.matrices();
    ctx.font = 'bold 12px system-ui, sans-serif';
    ctx.textAlign = 'center';
    ctx.textBaseline = 'middle';
    const sel = this.selected;
    if (sel) {
      const at = this.position(sel.primitive, sel.vertex);
      const s = at && this.project(at, m);
      if (s) {
        ctx.strokeStyle = '#ffffff';
        ctx.lineWidth = 2;
        ctx.beginPath();
        ctx.arc(s[0], s[1], 12, 0, Math.PI * 2);
        ctx.stroke();
      }
    }
    for (const mk of this.markers) {
      const at = this.position(mk.primitive, mk.vertex);
      const s = at && this.project(at, m);
      if (!s) continue;
      ctx.fillStyle = mk.reached === false ? '#ff5a52' : '#4aa3ff';
      ctx.beginPath();
      ctx.arc(s[0], s[1], 8, 0, Math.PI * 2);
      ctx.fill();
      ctx.fillStyle = '#000';
      ctx.fillText(String(mk.number), s[0], s[1] + 0.5);
      if (mk.label && sameAs(mk, this.selected)) {
        ctx.fillStyle = '#e4e6ea';
        ctx.textAlign = 'left';
        ctx.fillText(mk.label, s[0] + 11, s[1]);
        ctx.textAlign = 'center';
      }
    }
  }

  // The ray through a point of the canvas (CSS pixels).
  ray(x, y) {
    const m = this.matrices();
    const nx = (x / this.canvas.clientWidth) * 2 - 1;
    const ny = 1 - (y / this.canvas.clientHeight) * 2;
    const t = Math.tan(Math.PI / 8);
    const dir = normalize(add(add(m.forward, scale(m.right, nx * t * m.aspect)), scale(m.up, ny * t)));
    return { origin: m.eye, dir };
  }

  // The vertex nearest the cursor on the visible surface: the nearest hit
  // triangle's corner closest to the hit point.
  pick(x, y) {
    const { origin, dir } = this.ray(x, y);
    let best = null;
    for (const p of this.primitives) {
      const pos = p.positions;
      const idx = p.indices;
      for (let t = 0; t < idx.length; t += 3) {
        const a = idx[t] * 3, b = idx[t + 1] * 3, c = idx[t + 2] * 3;
        const e1 = [pos[b] - pos[a], pos[b + 1] - pos[a + 1], pos[b + 2] - pos[a + 2]];
        const e2 = [pos[c] - pos[a], pos[c + 1] - pos[a + 1], pos[c + 2] - pos[a + 2]];
        const h = cross(dir, e2);
        const det = dot(e1, h);
        if (Math.abs(det) < 1e-18) continue;
        const inv = 1 / det;
        const s = [origin[0] - pos[a], origin[1] - pos[a + 1], origin[2] - pos[a + 2]];
        const u = dot(s, h) * inv;
        if (u < 0 || u > 1) continue;
        const q = cross(s, e1);
        const v = dot(dir, q) * inv;
        if (v < 0 || u + v > 1) continue;
        const dist = dot(e2, q) * inv;
        if (dist <= 0 || (best && dist >= best.dist)) continue;
        best = { dist, primitive: p.index, corners: [idx[t], idx[t + 1], idx[t + 2]], positions: pos };
      }
    }
    if (!best) return null;
    const hit = add(origin, scale(dir, best.dist));
    let vertex = best.corners[0];
    let nearest = Infinity;
    for (const v of best.corners) {
      const d = Math.hypot(best.positions[v * 3] - hit[0], best.positions[v * 3 + 1] - hit[1], best.positions[v * 3 + 2] - hit[2]);
      if (d < nearest) {
        nearest = d;
        vertex = v;
      }
    }
    return { primitive: best.primitive, vertex };
  }

  listen() {
    const c = this.canvas;
    let drag = null;
    c.addEventListener('contextmenu', (e) => e.preventDefault());
    c.addEventListener('pointerdown', (e) => {
      c.setPointerCapture(e.pointerId);
      drag = { x: e.offsetX, y: e.offsetY, moved: false, pan: e.button === 2 || e.shiftKey };
    });
    c.addEventListener('pointermove', (e) => {
      if (!drag) {
        this.showHover(e.offsetX, e.offsetY);
        return;
      }
      const dx = e.offsetX - drag.x;
      const dy = e.offsetY - drag.y;
      if (Math.abs(dx) + Math.abs(dy) > 3) drag.moved = true;
      if (!drag.moved) return;
      drag.x = e.offsetX;
      drag.y = e.offsetY;
      const cam = this.camera;
      if (drag.pan) {
        const m = this.matrices();
        const k = (cam.distance * Math.tan(Math.PI / 8) * 2) / Math.max(c.clientHeight, 1);
        cam.target = add(cam.target, add(scale(m.right, -dx * k), scale(m.up, dy * k)));
      } else {
        cam.yaw -= dx * 0.008;
        cam.pitch = Math.max(-1.5, Math.min(1.5, cam.pitch + dy * 0.008));
      }
      this.draw();
    });
    c.addEventListener('pointerup', (e) => {
      if (drag && !drag.moved) {
        const picked = this.pick(e.offsetX, e.offsetY);
        this.handlers.onPick(picked);
      }
      drag = null;
    });
    c.addEventListener('pointerleave', () => { this.hover.hidden = true; });
    c.addEventListener('wheel', (e) => {
      e.preventDefault();
      this.camera.distance *= Math.exp(e.deltaY * 0.001);
      this.camera.distance = Math.max(this.camera.radius * 0.05, Math.min(this.camera.radius * 50, this.camera.distance));
      this.draw();
    }, { passive: false });
    window.addEventListener('resize', () => this.draw());
  }

  showHover(x, y) {
    if (this.hoverPending) return;
    this.hoverPending = true;
    requestAnimationFrame(() => {
      this.hoverPending = false;
      const picked = this.pick(x, y);
      if (!picked) {
        this.hover.hidden = true;
        return;
      }
      this.hover.hidden = false;
      const marker = this.markers.find((m) => sameAs(m, picked));
      this.hover.textContent = `vertex ${picked.vertex}` + (this.primitives.length > 1 ? ` (primitive ${picked.primitive})` : '') +
        (marker ? ` — ${marker.number}${marker.label ? `: ${marker.label}` : ''}` : '');
      this.hover.style.left = `${x + 14}px`;
      this.hover.style.top = `${y + 10}px`;
    });
  }
}

export class TextureView {
  constructor(canvas, handlers) {
    this.canvas = canvas;
    this.handlers = handlers;
    this.ctx = canvas.getContext('2d', { willReadFrequently: true });
    this.image = null;
    this.mesh = null;
    this.uvs = null;
    this.inChart = null;
    this.markers = [];
    this.zoom = 1;
    this.pan = [0, 0];
    // The image and the layout, drawn again only when they change.
    this.layer = document.createElement('canvas');
    this.layerKey = null;
    this.targetEls = [];
    this.listen();
  }

  setMesh(mesh) {
    this.mesh = mesh;
    this.zoom = 1;
    this.pan = [0, 0];
    this.layerKey = null;
    this.draw();
  }

  setImage(image) {
    this.image = image;
    this.layerKey = null;
    this.draw();
  }

  // The chart's UVs per primitive, which of their triangles are drawn from them;
  // `coarse` ({level, uvs}): its coarse level in place of the primitives it
  // covers; `written`: per primitive, the UV set as written per face corner
  // (the other charts and packed pieces are drawn from it, where they are).
  setLayout(uvs, inChart, coarse, written) {
    this.uvs = uvs;
    this.coarse = coarse || null;
    if (inChart) this.inChart = inChart;
    if (written) this.written = written;
    this.layerKey = null;
    this.draw();
  }

  // Markers: [{number, target: [u, v], result: [u, v] | null, reached, residual, selected}].
  setMarkers(markers) {
    this.markers = markers;
    this.draw();
  }

  frame() {
    const w = this.canvas.clientWidth;
    const h = this.canvas.clientHeight;
    const size = Math.min(w, h) - 24;
    const s = size * this.zoom;
    return { s, ox: (w - s) / 2 + this.pan[0], oy: (h - s) / 2 + this.pan[1] };
  }

  toScreen(uv, f = this.frame()) { return [f.ox + uv[0] * f.s, f.oy + uv[1] * f.s]; }

  toUv(x, y, f = this.frame()) { return [(x - f.ox) / f.s, (y - f.oy) / f.s]; }

  draw() {
    const c = this.canvas;
    const dpr = window.devicePixelRatio || 1;
    const w = Math.max(1, Math.round(c.clientWidth * dpr));
    const h = Math.max(1, Math.round(c.clientHeight * dpr));
    if (c.width !== w || c.height !== h) {
      c.width = w;
      c.height = h;
    }
    const f = this.frame();
    const key = `${w}x${h} ${f.s} ${f.ox} ${f.oy}`;
    if (this.layerKey !== key) {
      this.layer.width = w;
      this.layer.height = h;
      const lctx = this.layer.getContext('2d', { willReadFrequently: true });
      lctx.setTransform(dpr, 0, 0, dpr, 0, 0);
      lctx.fillStyle = '#15171a';
      lctx.fillRect(0, 0, c.clientWidth, c.clientHeight);
      this.drawBackground(lctx, f);
      this.drawLayout(lctx, f);
      this.layerKey = key;
    }
    const ctx = this.ctx;
    ctx.setTransform(1, 0, 0, 1, 0, 0);
    ctx.drawImage(this.layer, 0, 0);
    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
    this.drawResults(ctx, f);
    this.syncTargets(f);
    const c2 = this.canvas;
    c2.dataset.uvOriginX = String(f.ox);
    c2.dataset.uvOriginY = String(f.oy);
    c2.dataset.uvSize = String(f.s);
  }

  drawBackground(ctx, f) {
    if (this.image) {
      ctx.imageSmoothingEnabled = true;
      ctx.drawImage(this.image, f.ox, f.oy, f.s, f.s);
      ctx.fillStyle = 'rgba(0, 0, 0, 0.25)';
      ctx.fillRect(f.ox, f.oy, f.s, f.s);
    } else {
      const n = 16;
      for (let i = 0; i < n; i++) {
        for (let j = 0; j < n; j++) {
          ctx.fillStyle = (i + j) % 2 ? '#2d4c7e' : '#3a3f48';
          ctx.fillRect(f.ox + (i * f.s) / n, f.oy + (j * f.s) / n, f.s / n + 0.5, f.s / n + 0.5);
        }
      }
    }
    ctx.strokeStyle = '#6b7380';
    ctx.lineWidth = 1;
    ctx.strokeRect(f.ox, f.oy, f.s, f.s);
  }

  // The layout's edges, the solved chart's coloured by Sander stretch.
  drawLayout(ctx, f) {
    if (!this.mesh || (!this.uvs && !this.coarse)) return;
    const buckets = new Map();
    const others = new Path2D();
    let area3 = 0;
    let area2 = 0;
    const tris = [];
    const add = (pos, uv, idx, inChart, written) => {
      for (let t = 0; t < idx.length; t += 3) {
        const a = idx[t], b = idx[t + 1], c = idx[t + 2];
        if (inChart && !inChart[t / 3]) {
          // Another chart: where the file has it (a cut or packed piece's
          // corners are not its vertices' UVs); without it, not drawn.
          if (!written || written.length < (t + 3) * 2) continue;
          const at = [0, 1, 2].map((i) => this.toScreen([written[(t + i) * 2], written[(t + i) * 2 + 1]], f));
          others.moveTo(...at[0]); others.lineTo(...at[1]); others.lineTo(...at[2]); others.closePath();
          continue;
        }
        const pts = [a, b, c].map((v) => this.toScreen([uv[v * 2], uv[v * 2 + 1]], f));
        const s = triangleStretch(pos, uv, a, b, c);
        area3 += s.area3;
        area2 += s.area2;
        tris.push({ pts, s });
      }
    };
    const coarse = this.coarse;
    this.mesh.primitives.forEach((p, k) => {
      const uv = this.uvs && this.uvs[k];
      if (!uv || (coarse && coarse.level.primitives.has(k))) return;
      add(p.positions, uv, p.indices, this.inChart && this.inChart[k], this.written && this.written[k]);
    });
    if (coarse) add(coarse.level.positions, coarse.uvs, coarse.level.indices, null);
    // Stretch relative to the whole chart's scale (Sander's normalisation).
    const norm = area2 > 0 ? Math.sqrt(area2 / area3) : 1;
    const raster = tris.length > RASTER_ABOVE;
    if (raster) rasterEdges(ctx, tris, norm);
    for (const { pts, s } of raster ? [] : tris) {
      const value = Number.isFinite(s.l2) ? s.l2 * norm : Infinity;
      const key = stretchColour(value);
      if (!buckets.has(key)) buckets.set(key, new Path2D());
      const path = buckets.get(key);
      path.moveTo(...pts[0]); path.lineTo(...pts[1]); path.lineTo(...pts[2]); path.closePath();
    }
    ctx.lineWidth = 0.6;
    ctx.strokeStyle = 'rgba(200, 200, 200, 0.35)';
    ctx.stroke(others);
    for (const [colour, path] of buckets) {
      ctx.strokeStyle = colour;
      ctx.stroke(path);
    }
  }

  // Where each vertex is now (a dot; unreached: red, a line to its target
  // and the residual). The targets themselves are DOM elements (syncTargets).
  drawResults(ctx, f) {
    ctx.font = 'bold 12px system-ui, sans-serif';
    for (const m of this.markers) {
      if (!m.result) continue;
      const t = this.toScreen(m.target, f);
      const r = this.toScreen(m.result, f);
      if (!m.reached) {
        ctx.strokeStyle = '#ff5a52';
        ctx.lineWidth = 1.5;
        ctx.beginPath(); ctx.moveTo(...r); ctx.lineTo(...t); ctx.stroke();
        ctx.fillStyle = '#ff5a52';
        ctx.fillText(m.residual.toExponential(1), t[0] + 12, t[1] - 12);
      }
      ctx.fillStyle = m.reached ? '#ffffff' : '#ff5a52';
      ctx.beginPath(); ctx.arc(r[0], r[1], 3, 0, Math.PI * 2); ctx.fill();
    }
  }

  // One draggable, numbered element per target, over the canvas.
  syncTargets(f) {
    const box = this.canvas.parentElement;
    while (this.targetEls.length < this.markers.length) {
      const el = document.createElement('div');
      el.className = 'target-marker';
      el.setAttribute('data-testid', 'target-marker');
      this.listenTarget(el);
      box.appendChild(el);
      this.targetEls.push(el);
    }
    while (this.targetEls.length > this.markers.length) this.targetEls.pop().remove();
    this.markers.forEach((m, k) => {
      const el = this.targetEls[k];
      const [x, y] = this.toScreen(m.target, f);
      el.style.left = `${x}px`;
      el.style.top = `${y}px`;
      el.textContent = String(m.number);
      el.dataset.index = String(m.index);
      el.dataset.vertex = String(m.vertex);
      el.title = m.label ? `${m.number}: ${m.label} (vertex ${m.vertex})` : `${m.number}: vertex ${m.vertex}`;
      el.classList.toggle('unreached', m.reached === false);
      el.classList.toggle('selected', Boolean(m.selected));
    });
  }

  listenTarget(el) {
    let drag = null;
    el.addEventListener('pointerdown', (e) => {
      if (e.button !== 0) return;
      e.stopPropagation();
      el.setPointerCapture(e.pointerId);
      const marker = this.markers[Number(el.dataset.index)];
      if (!marker) return;
      drag = { marker, moved: false };
      this.handlers.onDragStart(marker);
    });
    el.addEventListener('pointermove', (e) => {
      if (!drag) return;
      drag.moved = true;
      const rect = this.canvas.getBoundingClientRect();
      this.handlers.onDrag(drag.marker, clampUv(this.toUv(e.clientX - rect.left, e.clientY - rect.top)), e.timeStamp);
    });
    const end = () => {
      if (drag) this.handlers.onDragEnd(drag.marker, drag.moved);
      drag = null;
    };
    el.addEventListener('pointerup', end);
    el.addEventListener('pointercancel', end);
  }

  listen() {
    const c = this.canvas;
    let drag = null;
    c.addEventListener('contextmenu', (e) => e.preventDefault());
    c.addEventListener('pointerdown', (e) => {
      c.setPointerCapture(e.pointerId);
      drag = e.button === 2 || e.button === 1 ? { pan: true, x: e.offsetX, y: e.offsetY } : { click: true };
    });
    c.addEventListener('pointermove', (e) => {
      if (!drag || !drag.pan) return;
      this.pan[0] += e.offsetX - drag.x;
      this.pan[1] += e.offsetY - drag.y;
      drag.x = e.offsetX;
      drag.y = e.offsetY;
      this.draw();
    });
    c.addEventListener('pointerup', (e) => {
      if (drag && drag.click) {
        const uv = this.toUv(e.offsetX, e.offsetY);
        if (uv[0] >= 0 && uv[0] <= 1 && uv[1] >= 0 && uv[1] <= 1) this.handlers.onPlace(uv);
      }
      drag = null;
    });
    c.addEventListener('wheel', (e) => {
      e.preventDefault();
      const f = this.frame();
      const before = this.toUv(e.offsetX, e.offsetY, f);
      this.zoom = Math.max(0.5, Math.min(40, this.zoom * Math.exp(-e.deltaY * 0.001)));
      const after = this.toScreen(before, this.frame());
      this.pan[0] += e.offsetX - after[0];
      this.pan[1] += e.offsetY - after[1];
      this.draw();
    }, { passive: false });
    window.addEventListener('resize', () => this.draw());
  }
}

function sameAs(marker, selected) {
  return selected && marker.vertex === selected.vertex && marker.primitive === selected.primitive;
}

function clampUv(uv) {
  return [Math.max(0, Math.min(1, uv[0])), Math.max(0, Math.min(1, uv[1]))];
}

// Sander's L2 stretch of one triangle (3D positions, UVs), and its areas.
export function triangleStretch(pos, uv, a, b, c) {
  const q = [a, b, c].map((v) => [pos[v * 3], pos[v * 3 + 1], pos[v * 3 + 2]]);
  const s = [a, b, c].map((v) => uv[v * 2]);
  const t = [a, b, c].map((v) => uv[v * 2 + 1]);
  const area2 = ((s[1] - s[0]) * (t[2] - t[0]) - (s[2] - s[0]) * (t[1] - t[0])) / 2;
  const area3 = Math.hypot(...cross(sub(q[1], q[0]), sub(q[2], q[0]))) / 2;
  if (Math.abs(area2) < 1e-30) return { l2: Infinity, area2: 0, area3 };
  const ss = add(add(scale(q[0], t[1] - t[2]), scale(q[1], t[2] - t[0])), scale(q[2], t[0] - t[1]));
  const st = add(add(scale(q[0], s[2] - s[1]), scale(q[1], s[0] - s[2])), scale(q[2], s[1] - s[0]));
  const Ss = scale(ss, 1 / (2 * area2));
  const St = scale(st, 1 / (2 * area2));
  const l2 = Math.sqrt((dot(Ss, Ss) + dot(St, St)) / 2);
  return { l2: area3 > 0 ? l2 : Infinity, area2: Math.abs(area2), area3 };
}
