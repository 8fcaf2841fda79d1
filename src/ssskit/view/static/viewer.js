// ssskit view: the live viewer's page (WebGL2, no library). A G-buffer pass (multiple float render targets,
// ssskit's layers and units: mm), the screen-space passes as the GLSL ES 3.00 fragment shaders ssskit
// exports (window.SSSKIT_DATA: data.js, written by ssskit.view.site), composite and display tone mapping.
// window.ssskit is the page's interface for tests and benchmarks (render, read back, change state).
'use strict';
(function () {
  const D = window.SSSKIT_DATA;
  const $ = (id) => document.getElementById(id);
  const status = (msg) => { $('status').textContent = msg; };
  const query = new URLSearchParams(location.search);
  const size = (name, def) => { const v = parseInt(query.get(name) || '', 10); return v > 0 && v <= 8192 ? v : def; };
  const W = size('w', 960), H = size('h', 540);
  const canvas = $('view');
  canvas.width = W; canvas.height = H;
  const gl = canvas.getContext('webgl2', { antialias: false, depth: false, preserveDrawingBuffer: true });
  if (!gl) { status('WebGL2 is not available in this browser'); throw new Error('no WebGL2'); }
  if (!gl.getExtension('EXT_color_buffer_float')) { status('this browser cannot render to float targets'); throw new Error('no EXT_color_buffer_float'); }
  const timerExt = query.get('timer') === 'wall' ? null : gl.getExtension('EXT_disjoint_timer_query_webgl2');

  // ---- shaders ------------------------------------------------------------------------------------------
  function compile(type, src, what) {
    const s = gl.createShader(type);
    gl.shaderSource(s, src);
    gl.compileShader(s);
    if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error(what + ': ' + gl.getShaderInfoLog(s));
    return s;
  }
  function link(vs, fs, what) {
    const p = gl.createProgram();
    gl.attachShader(p, compile(gl.VERTEX_SHADER, vs, what + ' (vertex)'));
    gl.attachShader(p, compile(gl.FRAGMENT_SHADER, fs, what));
    gl.linkProgram(p);
    if (!gl.getProgramParameter(p, gl.LINK_STATUS)) throw new Error(what + ': ' + gl.getProgramInfoLog(p));
    const u = {};
    const n = gl.getProgramParameter(p, gl.ACTIVE_UNIFORMS);
    for (let i = 0; i < n; ++i) { const name = gl.getActiveUniform(p, i).name.replace(/\[0\]$/, ''); u[name] = gl.getUniformLocation(p, name); }
    return { p, u };
  }
  // a full-screen triangle from gl_VertexID (no attributes)
  const FULL_VS = '#version 300 es\nvoid main() { vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));\n' +
    '  gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0); }\n';
  const programs = new Map();
  function passProgram(text, defines, what) {
    // an engine's -D: the defines go right after the #version line of the exported text, which is kept as is
    const key = defines + '\n' + text;
    if (!programs.has(key)) {
      const nl = text.indexOf('\n');
      programs.set(key, link(FULL_VS, text.slice(0, nl + 1) + defines + text.slice(nl + 1), what));
    }
    return programs.get(key);
  }

  const GBUF_VS = `#version 300 es
in vec3 a_pos;
in vec3 a_nrm;
uniform mat4 u_view;
uniform mat4 u_proj;
out vec3 v_nrm;
out vec3 v_world;
out float v_z;
void main() {
  vec4 vp = u_view * vec4(a_pos, 1.0);
  v_z = -vp.z;            // linear view depth (mm: the scene is in mm)
  v_nrm = a_nrm;
  v_world = a_pos;
  gl_Position = u_proj * vp;
}`;
  // The G-buffer of ssskit.screenspace.GBuffer: diffuse = the lighting of a white Lambertian surface, each
  // light's intensity being E / pi of a surface facing it (ssskit.scenes.scenefile); no shadows.
  const GBUF_FS = `#version 300 es
precision highp float;
in vec3 v_nrm;
in vec3 v_world;
in float v_z;
uniform vec3 u_light_dir[4];
uniform vec3 u_light_rgb[4];
uniform int u_nlights;
uniform vec3 u_eye;
uniform vec3 u_albedo;
uniform float u_profile;
uniform vec3 u_lo;       // the light map: its corner, axes (texels along u_lu, u_lv), direction to the light
uniform vec3 u_lu;
uniform vec3 u_lv;
uniform vec3 u_ll;
uniform float u_ltexel;  // mm per map texel
layout(location = 0) out vec4 o_src;     // diffuse irradiance rgb, linear depth mm (-1 without SSS)
layout(location = 1) out vec4 o_spec;    // specular rgb
layout(location = 2) out vec4 o_albedo;  // albedo rgb, 1 on surfaces
layout(location = 3) out vec4 o_normal;  // world normal, linear depth mm
layout(location = 4) out vec4 o_id;      // profile id (0: no SSS)
layout(location = 5) out vec4 o_light;   // the transmittance pass's inputs: map texel x, y, depth along the light (mm), N . L
void main() {
  vec3 n = normalize(v_nrm);
  vec3 v = normalize(u_eye - v_world);
  if (dot(n, v) < 0.0) n = -n;
  vec3 e = vec3(0.0), s = vec3(0.0);
  for (int i = 0; i < 4; ++i) {
    if (i >= u_nlights) break;
    vec3 l = u_light_dir[i];
    float nl = max(dot(n, l), 0.0);
    e += u_light_rgb[i] * nl;
    vec3 h = normalize(l + v);
    s += u_light_rgb[i] * nl * 0.028 * 6.0 * pow(max(dot(n, h), 0.0), 40.0);  // a glossy coat (F0 = 0.028)
  }
  o_src = vec4(e, u_profile > 0.0 ? v_z : -1.0);
  o_spec = vec4(s, 1.0);
  o_albedo = vec4(u_albedo, 1.0);
  o_normal = vec4(n, v_z);
  o_id = vec4(u_profile, 0.0, 0.0, 0.0);
  vec3 d = v_world - u_lo;
  o_light = vec4(dot(d, u_lu) / u_ltexel, dot(d, u_lv) / u_ltexel, -dot(d, u_ll), dot(n, u_ll));
}`;
  // the key light's depth map (orthographic along the light, mm from the map's plane): the translucency shadow
  // map of Jimenez et al. 2010 that the transmittance pass reads
  const LMAP = 1024;
  const LIGHT_VS = `#version 300 es
in vec3 a_pos;
uniform vec3 u_lo;
uniform vec3 u_lu;
uniform vec3 u_lv;
uniform vec3 u_ll;
uniform float u_ltexel;
uniform float u_lrange;
out float v_z;
void main() {
  vec3 d = a_pos - u_lo;
  v_z = -dot(d, u_ll);
  gl_Position = vec4(2.0 * dot(d, u_lu) / (u_ltexel * ${LMAP}.0) - 1.0, 2.0 * dot(d, u_lv) / (u_ltexel * ${LMAP}.0) - 1.0,
                     2.0 * v_z / u_lrange - 1.0, 1.0);
}`;
  const LIGHT_FS = `#version 300 es
precision highp float;
in float v_z;
out vec4 o_depth;
void main() { o_depth = vec4(v_z, 0.0, 0.0, 1.0); }`;
  const COMPOSITE_FS = `#version 300 es
precision highp float;
uniform sampler2D u_src;
uniform sampler2D u_sss;
uniform sampler2D u_spec;
uniform sampler2D u_albedo;
uniform highp isampler2D u_counts;
uniform sampler2D u_trans;
uniform int u_transmission;
uniform int u_split;
uniform int u_heat;
uniform vec2 u_budget;
uniform float u_exposure;
out vec4 o_color;
void main() {
  ivec2 q = ivec2(gl_FragCoord.xy);
  vec4 src = texelFetch(u_src, q, 0);
  if (texelFetch(u_albedo, q, 0).a == 0.0) { o_color = vec4(0.13, 0.13, 0.13, 1.0); return; }
  if (u_heat == 1) {   // the adaptive sample count: b_min blue, b_max red
    float t = clamp((float(texelFetch(u_counts, q, 0).r) - u_budget.x) / max(u_budget.y - u_budget.x, 1.0), 0.0, 1.0);
    o_color = vec4(clamp(vec3(1.5 - abs(4.0 * t - 3.0), 1.5 - abs(4.0 * t - 2.0), 1.5 - abs(4.0 * t - 1.0)), 0.0, 1.0), 1.0);
    return;
  }
  vec3 e = (u_split == 1 && q.x < ${W >> 1}) ? src.rgb : texelFetch(u_sss, q, 0).rgb;
  vec3 c = texelFetch(u_albedo, q, 0).rgb * e + texelFetch(u_spec, q, 0).rgb;
  // the transmitted light, T E / pi / albedo added to the diffuse layer before the albedo multiply (ssskit's pipeline)
  if (u_transmission == 1 && !(u_split == 1 && q.x < ${W >> 1})) c += texelFetch(u_trans, q, 0).rgb / 3.14159265358979;
  c *= u_exposure;
  c = c / (1.0 + c);                                   // Reinhard tone mapping
  c = mix(12.92 * c, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(0.0031308, c));   // sRGB encoding
  if (u_split == 1 && q.x == ${W >> 1}) c = vec3(1.0);
  o_color = vec4(c, 1.0);
}`;

  // ---- targets ------------------------------------------------------------------------------------------
  function floatTexture(format) {
    const t = gl.createTexture();
    gl.bindTexture(gl.TEXTURE_2D, t);
    gl.texStorage2D(gl.TEXTURE_2D, 1, format || gl.RGBA32F, W, H);
    for (const k of [gl.TEXTURE_MIN_FILTER, gl.TEXTURE_MAG_FILTER]) gl.texParameteri(gl.TEXTURE_2D, k, gl.NEAREST);
    return t;
  }
  function framebuffer(textures, depth) {
    const fb = gl.createFramebuffer();
    gl.bindFramebuffer(gl.FRAMEBUFFER, fb);
    textures.forEach((t, i) => gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0 + i, gl.TEXTURE_2D, t, 0));
    if (depth) {
      const rb = gl.createRenderbuffer();
      gl.bindRenderbuffer(gl.RENDERBUFFER, rb);
      gl.renderbufferStorage(gl.RENDERBUFFER, gl.DEPTH_COMPONENT32F, W, H);
      gl.framebufferRenderbuffer(gl.FRAMEBUFFER, gl.DEPTH_ATTACHMENT, gl.RENDERBUFFER, rb);
    }
    gl.drawBuffers(textures.map((_, i) => gl.COLOR_ATTACHMENT0 + i));
    if (gl.checkFramebufferStatus(gl.FRAMEBUFFER) !== gl.FRAMEBUFFER_COMPLETE) throw new Error('incomplete framebuffer');
    return fb;
  }
  function intTexture() {
    const t = gl.createTexture();
    gl.bindTexture(gl.TEXTURE_2D, t);
    gl.texStorage2D(gl.TEXTURE_2D, 1, gl.R32I, W, H);
    for (const k of [gl.TEXTURE_MIN_FILTER, gl.TEXTURE_MAG_FILTER]) gl.texParameteri(gl.TEXTURE_2D, k, gl.NEAREST);
    return t;
  }
  // float32 where a pass reads the layer (and the parity tests read it back); half floats for what only the
  // composite reads (specular, albedo, normal)
  const G = { src: floatTexture(), spec: floatTexture(gl.RGBA16F), albedo: floatTexture(gl.RGBA16F),
    normal: floatTexture(gl.RGBA16F), id: floatTexture(gl.R32F), light: floatTexture() };
  const gbufFb = framebuffer([G.src, G.spec, G.albedo, G.normal, G.id, G.light], true);
  const lightMap = gl.createTexture();
  gl.bindTexture(gl.TEXTURE_2D, lightMap);
  gl.texStorage2D(gl.TEXTURE_2D, 1, gl.R32F, LMAP, LMAP);
  for (const k of [gl.TEXTURE_MIN_FILTER, gl.TEXTURE_MAG_FILTER]) gl.texParameteri(gl.TEXTURE_2D, k, gl.NEAREST);
  const lightFb = (() => {
    const fb = gl.createFramebuffer();
    gl.bindFramebuffer(gl.FRAMEBUFFER, fb);
    gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, lightMap, 0);
    const rb = gl.createRenderbuffer();
    gl.bindRenderbuffer(gl.RENDERBUFFER, rb);
    gl.renderbufferStorage(gl.RENDERBUFFER, gl.DEPTH_COMPONENT32F, LMAP, LMAP);
    gl.framebufferRenderbuffer(gl.FRAMEBUFFER, gl.DEPTH_ATTACHMENT, gl.RENDERBUFFER, rb);
    return fb;
  })();
  const trans = floatTexture();
  const transFb = framebuffer([trans], false);
  // the adaptive pass: two histories and two count images, read one, write the other, swap
  const hist = [floatTexture(), floatTexture()], counts = [intTexture(), intTexture()];
  const updateFb = [0, 1].map((i) => framebuffer([hist[i], counts[i]], false));
  const countFb = [0, 1].map((i) => framebuffer([counts[i]], false));
  const histFb = [0, 1].map((i) => framebuffer([hist[i]], false));
  const T = [floatTexture(), floatTexture(), floatTexture()];
  const TF = T.map((t) => framebuffer([t], false));

  // ---- the scene --------------------------------------------------------------------------------------------
  function decode(b64, Type) {
    const bin = atob(b64);
    const u8 = new Uint8Array(bin.length);
    for (let i = 0; i < bin.length; ++i) u8[i] = bin.charCodeAt(i);
    return new Type(u8.buffer);
  }
  const S = D.scene;
  const vao = gl.createVertexArray();
  const gbuf = link(GBUF_VS, GBUF_FS, 'G-buffer');
  gl.bindVertexArray(vao);
  for (const [name, data] of [['a_pos', S.positions], ['a_nrm', S.normals]]) {
    const b = gl.createBuffer();
    gl.bindBuffer(gl.ARRAY_BUFFER, b);
    gl.bufferData(gl.ARRAY_BUFFER, decode(data, Float32Array), gl.STATIC_DRAW);
    const loc = gl.getAttribLocation(gbuf.p, name);
    gl.enableVertexAttribArray(loc);
    gl.vertexAttribPointer(loc, 3, gl.FLOAT, false, 0, 0);
  }
  const ib = gl.createBuffer();
  gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, ib);
  gl.bufferData(gl.ELEMENT_ARRAY_BUFFER, decode(S.indices, Uint32Array), gl.STATIC_DRAW);
  gl.bindVertexArray(null);
  const emptyVao = gl.createVertexArray();
  // a closed mesh wound consistently (ssskit.scenes.meshes.topology): its back faces are hidden, so culled
  function cull(on) {
    if (on && S.cull !== 'none') { gl.enable(gl.CULL_FACE); gl.cullFace(S.cull === 'back' ? gl.BACK : gl.FRONT); }
    else gl.disable(gl.CULL_FACE);
  }

  // ---- camera: the scene's look-at, orbiting its target -------------------------------------------------------
  const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
  const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
  const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
  const norm = (a) => { const l = Math.hypot(a[0], a[1], a[2]); return [a[0] / l, a[1] / l, a[2] / l]; };
  const cam = { az: 0, el: 0, zoom: 1 };
  function eye() {
    const c = S.camera, up = norm(c.up), off = sub(c.origin, c.target);
    const r = Math.hypot(off[0], off[1], off[2]) * cam.zoom;
    const back = norm(sub(off, up.map((u) => u * dot(off, up))));
    const side = cross(up, back);
    const el0 = Math.asin(Math.max(-1, Math.min(1, dot(norm(off), up))));
    const el = Math.max(-1.5, Math.min(1.5, el0 + cam.el));
    const dir = [0, 1, 2].map((i) => Math.cos(el) * (Math.cos(cam.az) * back[i] + Math.sin(cam.az) * side[i]) + Math.sin(el) * up[i]);
    return c.target.map((t, i) => t + r * dir[i]);
  }
  function matrices() {
    const c = S.camera, e = eye();
    const f = norm(sub(c.target, e)), r = norm(cross(f, c.up)), u = cross(r, f);
    const view = [r[0], u[0], -f[0], 0, r[1], u[1], -f[1], 0, r[2], u[2], -f[2], 0,
      -dot(r, e), -dot(u, e), dot(f, e), 1];
    const tx = Math.tan(c.fov_x_deg * Math.PI / 360), ty = tx * H / W;
    const dist = Math.hypot(...sub(e, c.target));
    const near = Math.max(dist * 0.01, 0.1), far = dist * 10;
    const proj = [1 / tx, 0, 0, 0, 0, 1 / ty, 0, 0, 0, 0, -(far + near) / (far - near), -1, 0, 0, -2 * far * near / (far - near), 0];
    return { view, proj, eye: e, fx: 0.5 * W / tx, fy: 0.5 * H / ty };
  }

  // ---- hashes (ssskit.sampling.hashes) -----------------------------------------------------------------------
  function mix32(h) {
    h >>>= 0;
    h ^= h >>> 16; h = Math.imul(h, 0x7FEB352D) >>> 0;
    h ^= h >>> 15; h = Math.imul(h, 0x846CA68B) >>> 0;
    h ^= h >>> 16;
    return h >>> 0;
  }
  const frameBase = (frame, seed) => mix32((mix32((seed ^ 0x9E3779B9) >>> 0) ^ frame) >>> 0);

  // ---- state and controls --------------------------------------------------------------------------------------
  const state = { material: D.default_material, pass: 'separable', spp: 16, split: false, heat: false, transmission: true, auto: true, frame: 0, seed: 0,
    light: { az: 0, el: 0, scale: 1 }, frames: 16 };
  const composite = link(FULL_VS, COMPOSITE_FS, 'composite');
  const timing = { mode: timerExt ? 'GPU timer queries (EXT_disjoint_timer_query_webgl2)' : 'wall time to a finished readback', passes: {}, frame_ms: 0 };
  let pending = [];

  function lights() {
    const dirs = [], rgb = [];
    const rot = (v) => {   // the light rig turned by the controls: azimuth about the camera's up, then elevation
      const up = norm(S.camera.up);
      const ca = Math.cos(state.light.az), sa = Math.sin(state.light.az);
      const k = cross(up, v);
      let w = [0, 1, 2].map((i) => v[i] * ca + k[i] * sa + up[i] * dot(up, v) * (1 - ca));
      const side = norm(cross(up, w).some((x) => x) ? cross(up, w) : [1, 0, 0]);
      const ce = Math.cos(state.light.el), se = Math.sin(state.light.el), k2 = cross(side, w);
      w = [0, 1, 2].map((i) => w[i] * ce + k2[i] * se + side[i] * dot(side, w) * (1 - ce));
      return norm(w);
    };
    for (const l of S.lights.slice(0, 4)) { dirs.push(...rot(l.direction)); rgb.push(...l.intensity.map((x) => x * state.light.scale)); }
    return { dirs, rgb, n: Math.min(4, S.lights.length) };
  }

  function timed(name, fn) {
    if (timerExt) {
      const q = gl.createQuery();
      gl.beginQuery(timerExt.TIME_ELAPSED_EXT, q);
      fn();
      gl.endQuery(timerExt.TIME_ELAPSED_EXT);
      pending.push([name, q, frames]);
    } else {
      const t0 = performance.now();
      fn();
      sync();
      timing.passes[name] = performance.now() - t0;
    }
  }
  // wait for the GPU: a one-pixel readback (gl.finish() need not block in a browser)
  const pixel = new Uint8Array(4);
  function sync() {
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);
    gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, pixel);
  }
  function collectQueries() {
    if (!timerExt || !pending.length) return;
    const last = pending[pending.length - 1][1];
    if (!gl.getQueryParameter(last, gl.QUERY_RESULT_AVAILABLE)) return;
    if (!gl.getParameter(timerExt.GPU_DISJOINT_EXT)) {   // the last frame's passes only (a frame behind)
      timing.passes = {};
      const lastFrame = pending[pending.length - 1][2];
      for (const [name, q, f] of pending) if (f === lastFrame) timing.passes[name] = gl.getQueryParameter(q, gl.QUERY_RESULT) / 1e6;
    }
    pending.forEach(([, q]) => gl.deleteQuery(q));
    pending = [];
  }

  function bindTextures(prog, named) {
    let unit = 0;
    for (const [name, tex] of Object.entries(named)) {
      if (!(name in prog.u)) continue;
      gl.activeTexture(gl.TEXTURE0 + unit);
      gl.bindTexture(gl.TEXTURE_2D, tex);
      gl.uniform1i(prog.u[name], unit++);
    }
  }
  const setIf = (prog, name, fn) => { if (name in prog.u && prog.u[name] !== null) fn(prog.u[name]); };

  // the light map's frame: the key light (the first) looking at the mesh's bounding sphere
  function lightView(L) {
    const l = L.dirs.slice(0, 3), c = S.bounds.centre, r = S.bounds.radius * 1.02;
    const a = Math.abs(l[0]) < 0.9 ? [1, 0, 0] : [0, 1, 0];
    const u = norm(cross(a, l)), v = cross(l, u);
    const o = [0, 1, 2].map((i) => c[i] - r * u[i] - r * v[i] + r * l[i]);
    return { o, u, v, l, texel: 2 * r / LMAP, range: 2 * r };
  }
  function lightUniforms(prog, L) {
    const lv = lightView(L);
    gl.uniform3fv(prog.u.u_lo, lv.o);
    gl.uniform3fv(prog.u.u_lu, lv.u);
    gl.uniform3fv(prog.u.u_lv, lv.v);
    gl.uniform3fv(prog.u.u_ll, lv.l);
    gl.uniform1f(prog.u.u_ltexel, lv.texel);
    setIf(prog, 'u_lrange', (loc) => gl.uniform1f(loc, lv.range));
  }
  const lightProg = link(LIGHT_VS, LIGHT_FS, 'light map');
  function drawLightMap() {
    gl.bindFramebuffer(gl.FRAMEBUFFER, lightFb);
    gl.viewport(0, 0, LMAP, LMAP);
    gl.enable(gl.DEPTH_TEST);
    gl.clearBufferfv(gl.COLOR, 0, [Infinity, 0, 0, 1]);   // no surface: no depth (the pass leaves it out)
    gl.clearBufferfv(gl.DEPTH, 0, [1]);
    gl.useProgram(lightProg.p);
    lightUniforms(lightProg, lights());
    drawMesh();
    gl.viewport(0, 0, W, H);
  }
  function transmission(mat) {
    drawLightMap();
    const prog = passProgram(mat.transmission.shader, '', 'transmittance pass');
    gl.useProgram(prog.p);
    bindTextures(prog, { u_id: G.id, u_lightspace: G.light, u_shadow: lightMap });
    setIf(prog, 'u_size', (l) => gl.uniform2i(l, W, H));
    setIf(prog, 'u_shadow_size', (l) => gl.uniform2i(l, LMAP, LMAP));
    const L = lights();
    setIf(prog, 'u_light_rgb', (l) => gl.uniform3fv(l, L.rgb.slice(0, 3).map((x) => Math.PI * x)));   // E = pi (E / pi)
    gl.bindFramebuffer(gl.FRAMEBUFFER, transFb);
    gl.drawArrays(gl.TRIANGLES, 0, 3);
  }

  let result = G.src;   // the texture holding the last pass's output (the diffuse layer)
  function drawGbuffer(m, mat) {
    gl.bindFramebuffer(gl.FRAMEBUFFER, gbufFb);
    gl.viewport(0, 0, W, H);
    gl.enable(gl.DEPTH_TEST);
    gl.clearBufferfv(gl.COLOR, 0, [0, 0, 0, -1]);
    for (let i = 1; i < 6; ++i) gl.clearBufferfv(gl.COLOR, i, [0, 0, 0, 0]);
    gl.clearBufferfv(gl.DEPTH, 0, [1]);
    gl.useProgram(gbuf.p);
    gl.uniformMatrix4fv(gbuf.u.u_view, false, m.view);
    gl.uniformMatrix4fv(gbuf.u.u_proj, false, m.proj);
    const L = lights();
    gl.uniform3fv(gbuf.u.u_light_dir, L.dirs);
    gl.uniform3fv(gbuf.u.u_light_rgb, L.rgb);
    gl.uniform1i(gbuf.u.u_nlights, L.n);
    gl.uniform3fv(gbuf.u.u_eye, m.eye);
    gl.uniform3fv(gbuf.u.u_albedo, mat.albedo);
    gl.uniform1f(gbuf.u.u_profile, 1);
    lightUniforms(gbuf, L);
    drawMesh();
  }
  // the mesh with the bound program and depth test (back faces culled where closed), then the state of the passes
  function drawMesh() {
    gl.bindVertexArray(vao);
    cull(true);
    gl.drawElements(gl.TRIANGLES, S.triangles * 3, gl.UNSIGNED_INT, 0);
    cull(false);
    gl.bindVertexArray(emptyVao);
    gl.disable(gl.DEPTH_TEST);
  }
  function drawPass(prog, target) {
    gl.bindFramebuffer(gl.FRAMEBUFFER, TF[target]);
    gl.drawArrays(gl.TRIANGLES, 0, 3);
  }
  function separable(m, mat) {
    const sp = mat.separable, base = frameBase(state.frame, state.seed);
    let sum = -1;
    for (let r = 0; r < sp.terms; ++r) {
      for (const vertical of [0, 1]) {
        const prog = passProgram(sp.shader, `#define VERTICAL ${vertical}\n#define TERM ${r}\n`, 'separable pass');
        gl.useProgram(prog.p);
        const out = vertical ? (sum === 1 ? 2 : 1) : 0;
        bindTextures(prog, vertical ? { u_src: T[0], u_dst: sum >= 0 ? T[sum] : T[0] } : { u_src: G.src, u_dst: G.src });
        setIf(prog, 'u_size', (l) => gl.uniform2i(l, W, H));
        setIf(prog, 'u_f', (l) => gl.uniform1f(l, vertical ? m.fy : m.fx));
        setIf(prog, 'u_base', (l) => gl.uniform1ui(l, base));
        setIf(prog, 'u_accumulate', (l) => gl.uniform1i(l, vertical && r > 0 ? 1 : 0));
        drawPass(prog, out);
        if (vertical) sum = out;
      }
    }
    return T[sum];
  }
  function burley(m, mat) {
    const prog = passProgram(mat.burley.shader, '', 'Burley pass');
    gl.useProgram(prog.p);
    bindTextures(prog, { u_src: G.src });
    setIf(prog, 'u_size', (l) => gl.uniform2i(l, W, H));
    setIf(prog, 'u_fx', (l) => gl.uniform1f(l, m.fx));
    setIf(prog, 'u_fy', (l) => gl.uniform1f(l, m.fy));
    setIf(prog, 'u_base', (l) => gl.uniform1ui(l, frameBase(state.frame, state.seed)));
    setIf(prog, 'u_spp', (l) => gl.uniform1i(l, state.spp));
    drawPass(prog, 1);
    return T[1];
  }
  // Xie 2020 Sec. 4.1 with a static camera: any change of the view, light or material starts a new history
  const ad = { key: '', cur: 0, frame: 0, used: 0 };
  function adaptive(m, mat) {
    const A = mat.adaptive;
    const key = JSON.stringify([state.material, cam, state.light, state.seed, W, H, A.settings]);
    setUniforms = (prog) => {
      setIf(prog, 'u_size', (l) => gl.uniform2i(l, W, H));
    };
    if (key !== ad.key) {            // no history: the estimate on an empty one gives b_min inside the mask
      ad.key = key; ad.cur = 0; ad.frame = 0;
      gl.bindFramebuffer(gl.FRAMEBUFFER, histFb[0]);
      gl.clearBufferfv(gl.COLOR, 0, [0, 0, 0, 0]);
      const est = passProgram(A.estimate, '', 'adaptive estimate');
      gl.useProgram(est.p);
      bindTextures(est, { u_hist: hist[0], u_mask: G.id });
      setUniforms(est);
      gl.bindFramebuffer(gl.FRAMEBUFFER, countFb[0]);
      gl.drawArrays(gl.TRIANGLES, 0, 3);
    }
    const c = ad.cur;
    const bur = passProgram(A.burley, '', 'Burley pass (count image)');
    gl.useProgram(bur.p);
    bindTextures(bur, { u_src: G.src, u_counts: counts[c] });
    setUniforms(bur);
    setIf(bur, 'u_fx', (l) => gl.uniform1f(l, m.fx));
    setIf(bur, 'u_fy', (l) => gl.uniform1f(l, m.fy));
    setIf(bur, 'u_base', (l) => gl.uniform1ui(l, frameBase(ad.frame, state.seed)));
    drawPass(bur, 1);
    const upd = passProgram(A.update, '', 'adaptive update');
    gl.useProgram(upd.p);
    bindTextures(upd, { u_hist: hist[c], u_mask: G.id, u_rgb: T[1], u_counts: counts[c] });
    setUniforms(upd);
    gl.bindFramebuffer(gl.FRAMEBUFFER, updateFb[1 - c]);
    gl.drawArrays(gl.TRIANGLES, 0, 3);
    ad.used = c; ad.cur = 1 - c; ad.frame += 1;
    return T[1];
  }
  let setUniforms = null;
  let lastPass = null;

  function render() {
    collectQueries();
    const mat = D.materials[state.material];
    const has = (part) => !!(mat[part] && !mat[part].error);   // a served page may still be asking for a part
    const m = matrices();
    const t0 = performance.now();
    timing.passes = timerExt ? timing.passes : {};
    gl.bindVertexArray(emptyVao);
    timed('gbuffer', () => drawGbuffer(m, mat));
    gl.viewport(0, 0, W, H);
    if (state.pass === 'separable') timed('separable', () => { result = separable(m, mat); });
    else if (state.pass === 'burley' && has('burley')) timed('burley', () => { result = burley(m, mat); });
    else if (state.pass === 'adaptive' && has('adaptive')) {
      if (lastPass !== 'adaptive') ad.key = '';   // switching to the adaptive pass starts a new history
      timed('adaptive', () => { result = adaptive(m, mat); });
    } else result = G.src;
    lastPass = state.pass;
    const transOn = state.transmission && has('transmission');
    if (transOn) timed('transmission', () => transmission(mat));
    timed('composite', () => {
      gl.bindFramebuffer(gl.FRAMEBUFFER, null);
      gl.useProgram(composite.p);
      bindTextures(composite, { u_src: G.src, u_sss: result, u_spec: G.spec, u_albedo: G.albedo, u_counts: counts[ad.used],
        u_trans: trans });
      gl.uniform1i(composite.u.u_transmission, transOn ? 1 : 0);
      gl.uniform1i(composite.u.u_split, state.split ? 1 : 0);
      gl.uniform1i(composite.u.u_heat, state.heat && state.pass === 'adaptive' && has('adaptive') ? 1 : 0);
      if (has('adaptive')) gl.uniform2f(composite.u.u_budget, mat.adaptive.b_min, mat.adaptive.b_max);
      gl.uniform1f(composite.u.u_exposure, 1.0);
      gl.drawArrays(gl.TRIANGLES, 0, 3);
    });
    sync();
    timing.frame_ms = performance.now() - t0;
    timing.fx = m.fx; timing.fy = m.fy;
    frames += 1;
    drawn = { material: state.material, transmission: transOn, frame: frames };
    const lines = Object.entries(timing.passes).map(([k, v]) => `${k.padEnd(10)} ${v.toFixed(2)} ms`);
    $('stats').textContent = `${W}x${H}, ${S.triangles} triangles\nframe ${timing.frame_ms.toFixed(1)} ms (` +
      `${(1000 / timing.frame_ms).toFixed(1)} fps, wall time to a finished readback)\n` + lines.join('\n') + `\nper pass: ${timing.mode}` +
      (S.about && S.about.attribution ? `\n${S.about.attribution}` : '');
    return JSON.parse(JSON.stringify(timing));
  }

  let frames = 0, dirty = true;
  let drawn = null;   // what the last frame showed: its material, whether with the transmittance pass
  function loop() {
    if (state.pass === 'adaptive' && state.auto && ad.frame < state.frames) dirty = true;
    if (dirty && state.auto) {
      dirty = false;
      try { render(); status(''); } catch (e) { status(String(e)); console.error(String(e)); }
    }
    requestAnimationFrame(loop);
  }
  const redraw = () => { dirty = true; };

  // ---- controls -------------------------------------------------------------------------------------------------
  // what the controls and the server say (the render loop owns #status: its errors)
  const notice = (msg) => { $('notice').textContent = msg; };
  function fillMaterials() {
    const sel = $('material');
    sel.innerHTML = '';
    const names = [...new Set([...Object.keys(D.materials), ...(D.presets || [])])];
    for (const name of names) sel.add(new Option(D.materials[name] ? D.materials[name].name : name, name, false, name === state.material));
    if (D.served) sel.add(new Option('albedo + mean free path...', '__artist__'));
  }
  fillMaterials();
  for (const t of D.tap_choices) $('taps').add(new Option(String(t), String(t), false, t === D.materials[state.material].separable.taps));
  const servedOnly = ['taps', 'jitter'];
  if (!D.served) servedOnly.forEach((id) => { $(id).disabled = true; $(id).title = 'served mode only (ssskit view without --out)'; });

  // served mode: the server computes a material's parts (ssskit.view.site.material_payload) when the page needs
  // them: the separable pass always, Burley and adaptive for those passes, the transmittance pass when it is on
  async function post(route, body) {
    return fetch(route, { method: 'POST', headers: { 'Content-Type': 'application/json' }, body: JSON.stringify(body) });
  }
  async function ask(body) {
    const r = await post('api/material', body);
    const j = await r.json();
    if (!r.ok) throw new Error(j.error || r.statusText);
    return j;
  }
  // the material of a key as the API names it: a preset, or the artists' terms it was asked with
  function materialBody(key) {
    const mat = D.materials[key];
    if (mat && mat.request && mat.request.albedo) return { albedo: mat.request.albedo, mfp: mat.request.mfp };
    return { material: key };
  }
  function neededParts() {
    const parts = ['separable'];
    if (state.pass === 'burley') parts.push('burley');
    if (state.pass === 'adaptive') parts.push('adaptive');
    return parts;
  }
  const missing = (key, parts) => parts.filter((p) => !(D.materials[key] && D.materials[key][p]));
  let pendingAsk = Promise.resolve();
  // merge a payload's parts into the page's data for key; a new separable pass or adaptive guide replaces the old
  function merge(key, payload) {
    const old = D.materials[key] || {};
    D.materials[key] = Object.assign({}, old, payload);
  }
  async function requestMaterial(body, key, extra) {
    // the fast parts first (the frame re-renders with them), then the transmittance pass where it is on
    const opts = { ...currentOptions(key), ...(extra || {}) };
    const first = neededParts();
    notice('computing the material...');
    const payload = await ask({ ...opts, ...body, parts: first });
    delete D.materials[key];
    merge(key, payload);
    state.material = key;
    fillMaterials();
    redraw();
    notice('');
    if (refOn) refreshReference();
    await ensureParts();
    return D.materials[key];
  }
  async function ensureParts() {
    const key = state.material;
    for (const parts of D.served ? [neededParts(), state.transmission ? ['transmission'] : []] : []) {
      const want = missing(key, parts);
      if (!want.length) continue;
      notice(`computing ${want.join(', ')}...`);
      merge(key, await ask({ ...materialBody(key), ...currentOptions(key), parts: want }));
      if (key === state.material) redraw();
    }
    const t = D.materials[key].transmission;
    notice(state.transmission && t && t.error ? `no transmittance pass for this material: ${t.error}` : '');
  }
  const ensure = () => { pendingAsk = pendingAsk.then(ensureParts).catch((e) => notice(String(e))); return pendingAsk; };
  function currentOptions(key) {
    const sep = D.materials[key] ? D.materials[key].separable : null;
    const opts = { kernel: sep ? sep.kernel : D.materials[state.material].separable.kernel, taps: parseInt($('taps').value, 10), jitter: parseFloat($('jitter').value) };
    if (adaptiveChanged) opts.adaptive = adaptiveSettings();
    return opts;
  }
  $('material').addEventListener('change', (e) => {
    const v = e.target.value;
    $('artist').hidden = v !== '__artist__';
    if (v === '__artist__') return;
    if (D.served && missing(v, neededParts()).length) {
      pendingAsk = pendingAsk.then(() => requestMaterial(materialBody(v), v)).catch((err) => notice(String(err)));
    } else { state.material = v; redraw(); ensure(); if (refOn) refreshReference(); }
  });
  $('apply').addEventListener('click', () => {
    const triple = (id) => $(id).value.split(',').map(Number);
    pendingAsk = pendingAsk.then(() => requestMaterial({ albedo: triple('albedo'), mfp: triple('mfp') }, 'artist')).catch((e) => notice(String(e)));
  });
  // a changed option makes every part of the material stale: the server rebuilds them (cached per option)
  function reaskAll() {
    const name = state.material, body = materialBody(name);
    pendingAsk = pendingAsk.then(() => requestMaterial(body, name)).catch((e) => notice(String(e)));
    return pendingAsk;
  }
  for (const id of ['taps', 'jitter']) $(id).addEventListener('change', reaskAll);

  // the adaptive pass's limits: inputs made from the ranges Python declares (D.adaptive_controls:
  // ssskit.view.site.adaptive_controls, from ssskit's AdaptivePass), checked here as there
  let adaptiveChanged = false;
  const controlsById = {};
  function checkControl(c, text) {
    const v = Number(text);
    const inRange = text.trim() !== '' && Number.isFinite(v) && (!c.integer || Number.isInteger(v)) &&
      (c.lo === null || (c.lo_open ? v > c.lo : v >= c.lo)) && (c.hi === null || (c.hi_open ? v < c.hi : v <= c.hi));
    return inRange ? null : `${c.name} must be ${c.integer ? 'an integer' : 'a number'} in ${c.interval}` +
      `${c.reason ? ' (' + c.reason + ')' : ''}, got ${JSON.stringify(text)}`;
  }
  function adaptiveSettings() {
    const out = {};
    for (const c of D.adaptive_controls) if (c.name !== 'frames') out[c.name] = Number($('ad_' + c.name).value);
    return out;
  }
  for (const c of D.adaptive_controls) {
    controlsById[c.name] = c;
    const label = document.createElement('label');
    label.textContent = c.name + ' ';
    const input = document.createElement('input');
    input.id = 'ad_' + c.name;
    input.type = 'text';
    input.size = 7;
    input.value = String(c.default);
    input.title = `${c.interval}${c.reason ? ': ' + c.reason : ''}`;
    if (c.served_only && !D.served) { input.disabled = true; input.title = 'served mode only (ssskit view without --out)'; }
    label.appendChild(input);
    $('adaptive_limits').appendChild(label);
    input.addEventListener('change', () => {
      const err = checkControl(c, input.value);
      input.classList.toggle('bad', !!err);
      if (err) { notice(err); return; }
      if (c.name === 'frames') { state.frames = Number(input.value); redraw(); notice(''); return; }
      const bad = D.adaptive_controls.filter((o) => o.served_only).map((o) => checkControl(o, $('ad_' + o.name).value)).find((x) => x) ||
        D.adaptive_order.map(([lo, hi]) => {   // AdaptiveSettings' rule across fields, as Python words it
          const a = Number($('ad_' + lo).value), b = Number($('ad_' + hi).value);
          return a <= b ? null : `the sample budget needs ${lo} <= ${hi}, got ${lo}=${a} > ${hi}=${b}`;
        }).find((x) => x);
      if (bad) { notice(bad); return; }
      adaptiveChanged = true;
      const key = state.material;
      pendingAsk = pendingAsk.then(async () => {
        notice('computing the adaptive pass...');
        merge(key, await ask({ ...materialBody(key), ...currentOptions(key), parts: ['adaptive'] }));
        redraw();
        notice('');
      }).catch((e) => notice(String(e)));
    });
  }
  state.frames = controlsById.frames ? controlsById.frames.default : 16;

  // export buttons: the engine formats of ssskit.export.FORMATS; the server writes the file through
  // ssskit.export.export (the code of ssskit export) and the page downloads its bytes
  for (const f of D.exports) {
    const row = document.createElement('div');
    row.className = 'export';
    const sel = document.createElement('select');
    sel.id = 'export_suffix_' + f.name;
    for (const s of f.suffixes) sel.add(new Option(s, s));
    const b = document.createElement('button');
    b.id = 'export_' + f.name;
    b.textContent = f.name;
    b.title = f.description;
    if (!D.served) { b.disabled = true; sel.disabled = true; b.title = 'export needs the served page: ssskit view (without --out)'; }
    b.addEventListener('click', () => exportFile(f.name, sel.value).catch((e) => notice(String(e))));
    row.append(b, sel);
    $('exports').appendChild(row);
  }
  $('export_note').textContent = D.served ? 'the current material, written by ssskit export' :
    'export needs the served page: run ssskit view (without --out)';
  async function exportFile(format, suffix) {
    notice(`exporting ${format}${suffix}...`);
    const r = await post('api/export', { ...materialBody(state.material), format, suffix });
    if (!r.ok) { const j = await r.json(); throw new Error(j.error || r.statusText); }
    const disp = r.headers.get('Content-Disposition') || '';
    const m = /filename="([^"]+)"/.exec(disp);
    const url = URL.createObjectURL(await r.blob());
    const a = document.createElement('a');
    a.href = url;
    a.download = m ? m[1] : `${state.material}_${format}${suffix}`;
    document.body.appendChild(a);
    a.click();
    a.remove();
    setTimeout(() => URL.revokeObjectURL(url), 10000);
    notice('');
  }
  // ---- the path-traced reference beside the frame (served mode; the head's views) ------------------------------------
  // The server answers the cached path trace of a view and preset (ssskit.view.site.reference_payload): its image,
  // shown unfiltered (one reference pixel, many screen pixels), its regions and their levels with standard errors.
  // The page's own level per region: mean(albedo x SSS (+ T / pi)) / mean(E / pi) over its pixels that fall in the
  // region (ssskit.metrics.region_level's effective albedo), from the current frame's float targets.
  const views = S.views || {};
  const viewNames = Object.keys(views);
  const sameCam = (a, b) => ['origin', 'target', 'up'].every((k) => a[k].every((v, i) => Math.abs(v - b[k][i]) < 1e-9)) &&
    Math.abs(a.fov_x_deg - b.fov_x_deg) < 1e-9;
  if (viewNames.length) {
    $('view_label').hidden = false;
    for (const v of viewNames) $('viewsel').add(new Option(v, v, false, sameCam(views[v], S.camera)));
    $('viewsel').addEventListener('change', (e) => {
      S.camera = views[e.target.value];
      cam.az = 0; cam.el = 0; cam.zoom = 1;
      redraw();
      refreshReference();
    });
  }
  if (!D.served) { $('reference').disabled = true; $('reference_label').title = 'served mode only (ssskit view without --out)'; }
  const refs = {};
  let refOn = false, levelsFrame = -1;
  const currentView = () => (viewNames.length ? $('viewsel').value : null);
  // why the frame and the reference are not of the same view, or '' where they are
  function moved() {
    const v = currentView();
    if (!v) return 'this scene has no named views';
    if (!sameCam(views[v], S.camera) || cam.az !== 0 || cam.el !== 0 || cam.zoom !== 1)
      return `the camera moved from the ${v} view: the reference is of that view (choose it again to return)`;
    if (state.light.az !== 0 || state.light.el !== 0) return "the light turned: the reference is lit by the scene's lights";
    return '';
  }
  async function refreshReference() {
    refOn = $('reference').checked && D.served;
    $('refside').hidden = !refOn;
    if (!refOn) return;
    const v = currentView();
    if (!v) { $('refnote').textContent = 'this scene has no path-traced reference (the head has, at its views)'; return; }
    const key = `${v}/${state.material}`;
    if (!refs[key]) {
      $('refnote').textContent = `reading the ${v} view's reference...`;
      const r = await post('api/reference', { view: v, material: state.material, w: W, h: H });
      const j = await r.json();
      refs[key] = r.ok ? j : { error: j.error || r.statusText };
    }
    drawReference(refs[key]);
    levelsFrame = -1;
    updateLevels();
  }
  function drawReference(ref) {
    const c = $('refimg');
    if (ref.error) { c.width = 0; $('reflevels').innerHTML = ''; $('refnote').textContent = ref.error; return; }
    const [w, h] = ref.size;
    c.width = w; c.height = h;
    c.style.height = `${H}px`;
    c.style.width = `${Math.round(H * w / h)}px`;
    const img = decode(ref.image, Float32Array), px = new ImageData(w, h);
    for (let i = 0; i < w * h; ++i) {
      for (let k = 0; k < 3; ++k) {   // the composite's display: Reinhard, then the sRGB encoding
        let x = img[3 * i + k]; x = x / (1 + x);
        x = x <= 0.0031308 ? 12.92 * x : 1.055 * Math.pow(x, 1 / 2.4) - 0.055;
        px.data[4 * i + k] = Math.round(255 * Math.min(1, Math.max(0, x)));
      }
      px.data[4 * i + 3] = 255;
    }
    c.getContext('2d').putImageData(px, 0, 0);
  }
  // a float target's texels, float32 RGBA, GL's rows (bottom first)
  function readFloat(tex) {
    const fb = gl.createFramebuffer();
    gl.bindFramebuffer(gl.FRAMEBUFFER, fb);
    gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, tex, 0);
    const out = new Float32Array(W * H * 4);
    gl.readPixels(0, 0, W, H, gl.RGBA, gl.FLOAT, out);
    gl.deleteFramebuffer(fb);
    return out;
  }
  // the page's level per region of ref over the current frame: {name: {pixels, level: [r, g, b]}}
  function pageLevels(ref) {
    const [w, h] = ref.size, labels = decode(ref.labels, Uint8Array);
    const mat = D.materials[state.material], transOn = state.transmission && mat.transmission && !mat.transmission.error;
    const src = readFloat(G.src), sss = readFloat(result), alb = readFloat(G.albedo), tr = transOn ? readFloat(trans) : null;
    const sums = ref.regions.map(() => ({ n: 0, out: [0, 0, 0], e: [0, 0, 0] }));
    for (let yg = 0; yg < H; ++yg) {
      const y = H - 1 - yg;   // GL's rows count from the bottom, the reference's from the top
      const row = Math.floor(h / 2 + (y + 0.5 - H / 2) * w / W);
      if (row < 0 || row >= h) continue;
      for (let x = 0; x < W; ++x) {
        const label = labels[row * w + Math.floor((x + 0.5) * w / W)];
        const i = 4 * (yg * W + x);
        if (!label || alb[i + 3] === 0) continue;
        const s = sums[label - 1];
        s.n += 1;
        for (let k = 0; k < 3; ++k) {
          s.out[k] += alb[i + k] * sss[i + k] + (tr ? tr[i + k] / Math.PI : 0);
          s.e[k] += src[i + k];
        }
      }
    }
    const out = {};
    ref.regions.forEach((name, j) => {
      const s = sums[j];
      out[name] = { pixels: s.n, level: s.n ? s.out.map((o, k) => o / s.e[k]) : null };
    });
    return out;
  }
  function updateLevels() {
    if (!refOn) return null;
    const ref = refs[`${currentView()}/${state.material}`];
    if (!ref || ref.error) return null;
    const why = moved();
    const mine = why ? null : pageLevels(ref);
    levelsFrame = frames;
    const f3 = (a) => (a ? a.map((x) => x.toFixed(3)).join(' ') : '-');
    const rows = ref.regions.map((name) => {
      const r = ref.levels[name], p = mine ? mine[name] : null;
      const se = r.se ? ' \u00b1 ' + r.se.map((x) => x.toFixed(3)).join(' ') : '';
      return `<tr><td>${name}</td><td>${r.pixels}</td><td>${f3(r.level)}${se}</td><td>${p ? f3(p.level) : '-'}</td></tr>`;
    });
    $('reflevels').innerHTML = '<tr><th>region</th><th>px</th><th>path trace (R G B \u00b1 SE)</th><th>this frame</th></tr>' + rows.join('');
    $('refnote').textContent = `${currentView()} view, ${state.material}: Mitsuba volpathmis, ${ref.spp} spp` +
      `${ref.converged ? '' : ' (not converged)'}; levels: mean(diffuse out) / mean(E / pi) per region over ` +
      `the reference rows ${ref.rows[0]}-${ref.rows[1]} this frame shows. The page's G-buffer has no shadows.` +
      (why ? `\n${why}` : '');
    return { reference: ref.levels, page: mine, moved: why };
  }
  $('reference').addEventListener('change', () => refreshReference().catch((e) => notice(String(e))));
  setInterval(() => { if (refOn && frames !== levelsFrame) updateLevels(); }, 300);

  $('pass').addEventListener('change', (e) => { state.pass = e.target.value; redraw(); ensure(); });
  $('spp').addEventListener('change', (e) => { state.spp = Math.max(1, Math.min(256, parseInt(e.target.value, 10) || 1)); redraw(); });
  $('split').addEventListener('change', (e) => { state.split = e.target.checked; redraw(); });
  $('heat').addEventListener('change', (e) => { state.heat = e.target.checked; redraw(); });
  $('transmission').addEventListener('change', (e) => { state.transmission = e.target.checked; redraw(); ensure(); });
  $('light_az').addEventListener('input', (e) => { state.light.az = e.target.value * Math.PI / 180; redraw(); });
  $('light_el').addEventListener('input', (e) => { state.light.el = e.target.value * Math.PI / 180; redraw(); });
  $('light_i').addEventListener('input', (e) => { state.light.scale = parseFloat(e.target.value); redraw(); });
  let drag = null;
  canvas.addEventListener('pointerdown', (e) => { drag = [e.clientX, e.clientY]; canvas.setPointerCapture(e.pointerId); });
  canvas.addEventListener('pointerup', () => { drag = null; });
  canvas.addEventListener('pointermove', (e) => {
    if (!drag) return;
    cam.az -= (e.clientX - drag[0]) * 0.01;
    cam.el += (e.clientY - drag[1]) * 0.01;
    drag = [e.clientX, e.clientY];
    redraw();
  });
  canvas.addEventListener('wheel', (e) => { e.preventDefault(); cam.zoom = Math.max(0.2, Math.min(5, cam.zoom * Math.exp(e.deltaY * 0.001))); redraw(); }, { passive: false });

  // ---- the page's interface (tests, benchmarks) -------------------------------------------------------------
  function toBase64(bytes) {
    let s = '';
    for (let i = 0; i < bytes.length; i += 0x8000) s += String.fromCharCode.apply(null, bytes.subarray(i, i + 0x8000));
    return btoa(s);
  }
  // the first channel of a framebuffer's colour target, base64 (read as RGBA, the format every driver reads)
  function readChannel(fb, w, h, Type, format, type) {
    gl.bindFramebuffer(gl.FRAMEBUFFER, fb);
    const out = new Type(w * h * 4);
    gl.readPixels(0, 0, w, h, format, type, out);
    const one = new Type(w * h);
    for (let i = 0; i < w * h; ++i) one[i] = out[4 * i];
    return toBase64(new Uint8Array(one.buffer));
  }
  window.ssskit = {
    size: [W, H],
    render,
    frames: () => frames,
    set(changes) {
      const { material, ...rest } = changes;
      Object.assign(state, rest);
      // a served page asks the server for a material it does not hold yet (ready() resolves when it is drawn)
      if (material !== undefined && !D.materials[material] && D.served) {
        pendingAsk = pendingAsk.then(() => requestMaterial(materialBody(material), material)).catch((e) => notice(String(e)));
      } else if (material !== undefined) state.material = material;
      redraw();
      ensure();
    },
    state: () => JSON.parse(JSON.stringify(state)),
    drawn: () => drawn,
    // resolves when the server has answered every part the page asked for (served mode)
    ready: () => pendingAsk,
    // the reference panel: its levels beside the page's of the last frame (after a render), or null
    referenceLevels: () => updateLevels(),
    showReference: (on) => { $('reference').checked = on; return refreshReference(); },
    orbit(daz, del) { cam.az += daz; cam.el += del; redraw(); },
    material: requestMaterial,
    shader(kind) { return D.materials[state.material][kind].shader; },
    adaptiveFrames: () => ad.frame,
    // the key light's depth map, base64 float32 (LMAP x LMAP, the map's rows as the pass reads them)
    readLightMap() { return readChannel(lightFb, LMAP, LMAP, Float32Array, gl.RGBA, gl.FLOAT); },
    lightMapSize: LMAP,
    lightRgb: () => lights().rgb.slice(0, 3).map((x) => Math.PI * x),
    // a float target as base64 float32 RGBA, GL's rows (bottom first): src, spec, albedo, normal, id, result,
    // history (the adaptive history after the last frame)
    read(name) {
      const tex = name === 'result' ? result : name === 'history' ? hist[ad.cur] : name === 'transmission' ? trans : G[name];
      return toBase64(new Uint8Array(readFloat(tex).buffer));
    },
    // the sample counts the last adaptive frame used (used) or the next frame's (next), base64 int32, GL's rows
    readCounts(which) {
      return readChannel(which === 'next' ? countFb[ad.cur] : countFb[ad.used], W, H, Int32Array, gl.RGBA_INTEGER, gl.INT);
    },
    // the displayed image as base64 RGBA8, GL's rows
    readDisplay() {
      gl.bindFramebuffer(gl.FRAMEBUFFER, null);
      const out = new Uint8Array(W * H * 4);
      gl.readPixels(0, 0, W, H, gl.RGBA, gl.UNSIGNED_BYTE, out);
      return toBase64(out);
    },
  };
  ensure();
  requestAnimationFrame(loop);
})();
