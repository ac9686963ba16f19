// FabHaL scene viewer: WebGL 2, no libraries, no network.
// It records its own health on <body>: data-errors (console errors and
// exceptions, "|"-separated) and data-rendered (pixels covered by the scene).
"use strict";
(function () {
  const errors = [];
  const record = (message) => { errors.push(String(message)); document.body.dataset.errors = errors.join(" | "); };
  window.addEventListener("error", (event) => record(event.message));
  const consoleError = console.error.bind(console);
  console.error = (...args) => { record(args.join(" ")); consoleError(...args); };
  document.body.dataset.errors = "";

  // Each connection's DoF values grouped by the side (part.primitive) they belong
  // to: slides ("t", "t1", "t2") as the fraction of the primitive's length, the
  // others as angles in degrees, already within their range in the summary.
  function dofsBySide(connection) {
    const sides = new Map();
    for (const [name, value] of Object.entries(connection.dofs)) {
      const cut = name.lastIndexOf(".");
      const owner = name.slice(0, cut);
      const dof = name.slice(cut + 1);
      const shown = dof.startsWith("t") ? `${dof} ${value.toFixed(3)} along` : `${dof} ${value.toFixed(1)}\u00b0`;
      if (!sides.has(owner)) sides.set(owner, []);
      sides.get(owner).push(shown);
    }
    return sides;
  }

  let data = JSON.parse(document.getElementById("scene-data").textContent);
  let summary = data.summary;
  const canvas = document.getElementById("canvas");
  const tip = document.getElementById("tip");
  buildPanel();
  document.body.dataset.status = summary.status;

  const gl = canvas.getContext("webgl2", { antialias: true, preserveDrawingBuffer: true });
  // `fabhal watch` replaces the scene in place (the camera stays where the user left it)
  window.fabhalViewer = { load: (next) => { data = next; summary = next.summary; buildPanel(); document.body.dataset.status = summary.status; } };
  if (!gl) {
    // a visible message, not a blank page; the panel still shows the result
    const message = document.createElement("div");
    message.id = "no-webgl";
    message.textContent = "This browser cannot show the 3D view: it offers no WebGL 2 (or has it " +
      "switched off). The panel on the right has the result; `fabhal render PROGRAM -o picture.png` " +
      "draws it as a picture instead.";
    canvas.replaceWith(message);
    document.body.dataset.webgl = "unavailable";
    return;
  }

  const decode = (text, Type) => {
    const bytes = Uint8Array.from(atob(text), (c) => c.charCodeAt(0));
    return new Type(bytes.buffer);
  };

  const VERTEX = `#version 300 es
    in vec3 position;
    uniform mat4 viewProjection;
    out vec3 world;
    void main() { world = position; gl_Position = viewProjection * vec4(position, 1.0); }`;
  const FRAGMENT = `#version 300 es
    precision highp float;
    in vec3 world;
    uniform vec4 color;
    uniform vec3 light;
    uniform int picking;
    out vec4 outColor;
    void main() {
      if (picking == 1) { outColor = color; return; }
      vec3 normal = normalize(cross(dFdx(world), dFdy(world)));  // flat shading, no normals needed
      float shade = 0.35 + 0.65 * abs(dot(normal, light));
      outColor = vec4(color.rgb * shade, color.a);
    }`;
  const program = link(VERTEX, FRAGMENT);
  const uniform = (name) => gl.getUniformLocation(program, name);
  const where = { viewProjection: uniform("viewProjection"), color: uniform("color"),
                  light: uniform("light"), picking: uniform("picking") };

  // geometry: one vertex array per item, plus the target axes as lines
  let meshes = [], axes = [], radius = 1, centre = [0, 0, 0];
  let framed = loadGeometry();  // false until a scene with parts has placed the camera
  const camera = { yaw: -0.95, pitch: 0.45, distance: radius * 3.2, target: centre.slice() };
  let hovered = -1;
  installControls();
  draw();
  document.body.dataset.rendered = String(coveredPixels());
  window.fabhalViewer.load = (next) => {
    data = next;
    summary = next.summary;
    buildPanel();
    if (loadGeometry() && !framed) {
      camera.distance = radius * 3.2;
      camera.target = centre.slice();
      framed = true;
    }
    hovered = -1;
    draw();
    document.body.dataset.status = summary.status;
    document.body.dataset.rendered = String(coveredPixels());
  };

  function loadGeometry() {
    for (const old of [...meshes, ...axes]) for (const buffer of old.buffers) gl.deleteBuffer(buffer);
    for (const old of [...meshes, ...axes]) gl.deleteVertexArray(old.vao);
    const low = [Infinity, Infinity, Infinity], high = [-Infinity, -Infinity, -Infinity];
    meshes = data.items.map((item, index) => {
      const positions = decode(item.positions, Float32Array);
      const indices = decode(item.indices, Uint32Array);
      if (item.role !== "environment") {
        for (let i = 0; i < positions.length; i += 3) {
          for (let k = 0; k < 3; k++) { low[k] = Math.min(low[k], positions[i + k]); high[k] = Math.max(high[k], positions[i + k]); }
        }
      }
      return { item, index, ...upload(positions, indices), count: indices.length };
    });
    const empty = !(low[0] <= high[0]);  // nothing but environments (or nothing yet)
    centre = empty ? [0, 0, 0] : low.map((v, k) => (v + high[k]) / 2);
    radius = empty ? 1 : Math.max(1, Math.hypot(high[0] - low[0], high[1] - low[1], high[2] - low[2]) / 2);
    axes = axisLines();
    return !empty;
  }

  function link(vertexSource, fragmentSource) {
    const compile = (type, source) => {
      const shader = gl.createShader(type);
      gl.shaderSource(shader, source);
      gl.compileShader(shader);
      if (!gl.getShaderParameter(shader, gl.COMPILE_STATUS)) record(gl.getShaderInfoLog(shader));
      return shader;
    };
    const p = gl.createProgram();
    gl.attachShader(p, compile(gl.VERTEX_SHADER, vertexSource));
    gl.attachShader(p, compile(gl.FRAGMENT_SHADER, fragmentSource));
    gl.bindAttribLocation(p, 0, "position");
    gl.linkProgram(p);
    if (!gl.getProgramParameter(p, gl.LINK_STATUS)) record(gl.getProgramInfoLog(p));
    return p;
  }

  function upload(positions, indices) {
    const vao = gl.createVertexArray();
    gl.bindVertexArray(vao);
    const buffer = gl.createBuffer();
    gl.bindBuffer(gl.ARRAY_BUFFER, buffer);
    gl.bufferData(gl.ARRAY_BUFFER, positions, gl.STATIC_DRAW);
    gl.enableVertexAttribArray(0);
    gl.vertexAttribPointer(0, 3, gl.FLOAT, false, 0, 0);
    const elements = gl.createBuffer();
    gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, elements);
    gl.bufferData(gl.ELEMENT_ARRAY_BUFFER, indices, gl.STATIC_DRAW);
    gl.bindVertexArray(null);
    return { vao, buffers: [buffer, elements] };
  }

  function axisLines() {
    // requested frame: long axes; achieved: short ones (x red, y green, z blue)
    const lines = [];
    const size = radius * 0.25;
    for (const [frame, length] of [[data.requested, size], [data.achieved, size * 0.6]]) {
      const origin = [frame[0][3], frame[1][3], frame[2][3]];
      for (let axis = 0; axis < 3; axis++) {
        const tip = origin.map((v, k) => v + length * frame[k][axis]);
        const vao = gl.createVertexArray();
        gl.bindVertexArray(vao);
        const buffer = gl.createBuffer();
        gl.bindBuffer(gl.ARRAY_BUFFER, buffer);
        gl.bufferData(gl.ARRAY_BUFFER, new Float32Array([...origin, ...tip]), gl.STATIC_DRAW);
        gl.enableVertexAttribArray(0);
        gl.vertexAttribPointer(0, 3, gl.FLOAT, false, 0, 0);
        gl.bindVertexArray(null);
        lines.push({ vao, buffers: [buffer], color: [[0.86, 0.16, 0.16], [0.16, 0.63, 0.16], [0.16, 0.31, 0.86]][axis] });
      }
    }
    return lines;
  }

  function viewProjection() {
    const aspect = canvas.width / Math.max(1, canvas.height);
    const eye = [
      camera.target[0] + camera.distance * Math.cos(camera.pitch) * Math.cos(camera.yaw),
      camera.target[1] + camera.distance * Math.cos(camera.pitch) * Math.sin(camera.yaw),
      camera.target[2] + camera.distance * Math.sin(camera.pitch),
    ];
    const near = camera.distance / 100, far = camera.distance * 20;
    return multiply(perspective(0.7, aspect, near, far), lookAt(eye, camera.target, [0, 0, 1]));
  }

  function resize() {
    const scale = window.devicePixelRatio || 1;
    const width = Math.max(1, Math.round(canvas.clientWidth * scale));
    const height = Math.max(1, Math.round(canvas.clientHeight * scale));
    if (canvas.width !== width || canvas.height !== height) { canvas.width = width; canvas.height = height; }
  }

  function draw(picking = false) {
    resize();
    gl.viewport(0, 0, canvas.width, canvas.height);
    gl.clearColor(picking ? 0 : 0.98, picking ? 0 : 0.98, picking ? 0 : 0.973, 1);
    gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    gl.enable(gl.DEPTH_TEST);
    gl.useProgram(program);
    gl.uniformMatrix4fv(where.viewProjection, false, viewProjection());
    const toCamera = [Math.cos(camera.pitch) * Math.cos(camera.yaw), Math.cos(camera.pitch) * Math.sin(camera.yaw), Math.sin(camera.pitch)];
    gl.uniform3fv(where.light, normalize(toCamera.map((v, k) => v + [0.2, 0.2, 0.5][k])));
    gl.uniform1i(where.picking, picking ? 1 : 0);
    // contacts lie where two bodies meet, hidden by one of them: drawn over everything
    const overlay = (m) => m.item.role === "contact" || m.item.role === "held";
    const overlays = meshes.filter(overlay);
    const solid = meshes.filter((m) => m.item.opacity >= 1 && !overlay(m));
    const ghosts = meshes.filter((m) => m.item.opacity < 1);
    gl.disable(gl.BLEND);
    for (const mesh of solid) drawMesh(mesh, picking);
    gl.disable(gl.DEPTH_TEST);
    for (const mesh of overlays) drawMesh(mesh, picking);
    gl.enable(gl.DEPTH_TEST);
    if (!picking) {
      gl.enable(gl.BLEND);
      gl.blendFunc(gl.SRC_ALPHA, gl.ONE_MINUS_SRC_ALPHA);
      gl.depthMask(false);
      for (const mesh of ghosts) drawMesh(mesh, false);
      gl.depthMask(true);
      gl.disable(gl.DEPTH_TEST);
      for (const line of axes) {
        gl.uniform4f(where.color, ...line.color, 1);
        gl.bindVertexArray(line.vao);
        gl.drawArrays(gl.LINES, 0, 2);
      }
      gl.enable(gl.DEPTH_TEST);
    }
    gl.bindVertexArray(null);
  }

  function drawMesh(mesh, picking) {
    let color = [...mesh.item.color, mesh.item.opacity];
    if (picking) color = [((mesh.index + 1) & 255) / 255, ((mesh.index + 1) >> 8) / 255, 0, 1];
    else if (mesh.index === hovered) color = color.map((v, k) => (k < 3 ? Math.min(1, v * 1.3 + 0.08) : v));
    gl.uniform4f(where.color, ...color);
    gl.bindVertexArray(mesh.vao);
    gl.drawElements(gl.TRIANGLES, mesh.count, gl.UNSIGNED_INT, 0);
  }

  function pick(x, y) {
    draw(true);
    const scale = window.devicePixelRatio || 1;
    const pixel = new Uint8Array(4);
    gl.readPixels(Math.round(x * scale), canvas.height - Math.round(y * scale) - 1, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, pixel);
    draw(false);
    return pixel[0] + (pixel[1] << 8) - 1;
  }

  function coveredPixels() {
    const pixels = new Uint8Array(canvas.width * canvas.height * 4);
    gl.readPixels(0, 0, canvas.width, canvas.height, gl.RGBA, gl.UNSIGNED_BYTE, pixels);
    let count = 0;
    for (let i = 0; i < pixels.length; i += 4) {
      if (Math.abs(pixels[i] - 250) + Math.abs(pixels[i + 1] - 250) + Math.abs(pixels[i + 2] - 248) > 12) count++;
    }
    return count;
  }

  function installControls() {
    let dragging = null;
    canvas.addEventListener("contextmenu", (event) => event.preventDefault());
    canvas.addEventListener("mousedown", (event) => {
      dragging = { x: event.clientX, y: event.clientY, pan: event.button === 2 || event.shiftKey };
      canvas.style.cursor = "grabbing";
    });
    window.addEventListener("mouseup", () => { dragging = null; canvas.style.cursor = "grab"; });
    canvas.addEventListener("mousemove", (event) => {
      const rect = canvas.getBoundingClientRect();
      if (dragging) {
        const dx = event.clientX - dragging.x, dy = event.clientY - dragging.y;
        dragging.x = event.clientX; dragging.y = event.clientY;
        if (dragging.pan) panBy(dx, dy);
        else {
          camera.yaw -= dx * 0.008;
          camera.pitch = Math.max(-1.5, Math.min(1.5, camera.pitch + dy * 0.008));
        }
        draw();
        return;
      }
      const index = pick(event.clientX - rect.left, event.clientY - rect.top);
      hovered = index >= 0 && index < meshes.length ? index : -1;
      draw();
      if (hovered >= 0) {
        const item = meshes[hovered].item;
        tip.textContent = `${item.name} (${item.role})`;
        tip.style.left = `${event.clientX - rect.left + 14}px`;
        tip.style.top = `${event.clientY - rect.top + 10}px`;
        tip.style.display = "block";
      } else tip.style.display = "none";
    });
    canvas.addEventListener("wheel", (event) => {
      event.preventDefault();
      camera.distance *= Math.exp(event.deltaY * 0.001);
      draw();
    }, { passive: false });
    window.addEventListener("resize", () => draw());
  }

  function panBy(dx, dy) {
    const right = [-Math.sin(camera.yaw), Math.cos(camera.yaw), 0];
    const up = [-Math.sin(camera.pitch) * Math.cos(camera.yaw), -Math.sin(camera.pitch) * Math.sin(camera.yaw), Math.cos(camera.pitch)];
    const step = camera.distance / Math.max(1, canvas.clientHeight) * 0.8;
    for (let k = 0; k < 3; k++) camera.target[k] += (-dx * right[k] + dy * up[k]) * step;
  }

  function buildPanel() {
    const panel = document.getElementById("panel");
    const live = document.getElementById("live");  // `fabhal watch`: its own lines stay first
    panel.replaceChildren();
    if (live) panel.appendChild(live);
    const add = (tag, text, className) => {
      const node = document.createElement(tag);
      if (text !== undefined) node.textContent = text;
      if (className) node.className = className;
      panel.appendChild(node);
      return node;
    };
    add("h1", data.title);
    add("div", summary.status.replace("_", " "), `status ${summary.status}`);
    const target = summary.target;
    if (target) {
      add("p", `target ${target.part}${target.primitive ? "." + target.primitive : ""}: ` +
        `${target.position_error_mm.toFixed(1)} mm and ${target.rotation_error_deg.toFixed(1)} deg from the requested frame ` +
        "(long axes: requested, short: achieved).");
    }
    for (const diagnostic of summary.diagnostics || []) {
      add("p", `${diagnostic.severity}[${diagnostic.code}]: ${diagnostic.message}`, diagnostic.severity === "error" ? "falls_apart" : "");
    }
    add("h2", "how it hangs").style.fontSize = "15px";
    const tree = add("div");
    for (const entry of data.tree) {
      const line = document.createElement("div");
      line.style.paddingLeft = `${entry.depth * 14}px`;
      const code = document.createElement("code");
      code.textContent = entry.line;
      line.appendChild(code);
      tree.appendChild(line);
    }
    add("h2", "connections").style.fontSize = "15px";
    const list = add("ul");
    for (const connection of summary.connections || []) {
      const item = document.createElement("li");
      const code = document.createElement("code");
      code.textContent = `${connection.a} -- ${connection.b}`;
      item.appendChild(code);
      if (connection.at_bound.length) item.appendChild(document.createTextNode(" (at an end)"));
      for (const [owner, values] of dofsBySide(connection)) {
        const line = document.createElement("div");
        line.className = "dofs";
        line.textContent = `${owner}: ${values.join(", ")}`;
        item.appendChild(line);
      }
      list.appendChild(item);
    }
    add("h2", "degrees of freedom").style.fontSize = "15px";
    const dofs = add("ul");
    dofs.id = "dofs";
    for (const dof of summary.dofs || []) {
      const item = document.createElement("li");
      const code = document.createElement("code");
      code.textContent = dof.name;
      item.appendChild(code);
      const range = dof.turns_freely ? "turns freely" : `${dof.range[0]} .. ${dof.range[1]}`;
      item.appendChild(document.createTextNode(`: ${dof.as_built} (${range}; ${dof.role}${dof.at_end ? ", at an end" : ""})`));
      dofs.appendChild(item);
    }
    add("h2", "parts").style.fontSize = "15px";
    const parts = add("ul");
    for (const [name, part] of Object.entries(summary.parts || {})) {
      const item = document.createElement("li");
      item.textContent = `${name}: ${part.type}, ${part.mass_g} g at (${part.pos.map((v) => v.toFixed(0)).join(", ")})`;
      parts.appendChild(item);
    }
  }

  // ---- small matrix helpers (column-major, as WebGL expects)
  function normalize(v) { const n = Math.hypot(...v) || 1; return v.map((x) => x / n); }
  function cross(a, b) { return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]; }
  function dot(a, b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
  function perspective(fov, aspect, near, far) {
    const f = 1 / Math.tan(fov / 2), r = 1 / (near - far);
    return [f / aspect, 0, 0, 0, 0, f, 0, 0, 0, 0, (far + near) * r, -1, 0, 0, 2 * far * near * r, 0];
  }
  function lookAt(eye, at, up) {
    const z = normalize(eye.map((v, k) => v - at[k])), x = normalize(cross(up, z)), y = cross(z, x);
    return [x[0], y[0], z[0], 0, x[1], y[1], z[1], 0, x[2], y[2], z[2], 0, -dot(x, eye), -dot(y, eye), -dot(z, eye), 1];
  }
  function multiply(a, b) {
    const out = new Array(16).fill(0);
    for (let c = 0; c < 4; c++) for (let r = 0; r < 4; r++) for (let k = 0; k < 4; k++) out[c * 4 + r] += a[k * 4 + r] * b[c * 4 + k];
    return new Float32Array(out);
  }
})();
