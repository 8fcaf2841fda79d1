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
  // The G-buffer of ssskit.screenspace.GBuffer in two draws (deferred shading): the mesh writes one target, the
  // world normal and the linear depth (mm); a full-screen resolve then writes the other layers once per pixel from
  // them. Writing six float targets per rasterised fragment (small triangles shade whole 2x2 quads, so several
  // fragments per pixel) cost SwiftShader more than the resolve's one pass (benchmarks/RESULTS.md, "The live viewer").
  const GEOM_FS = `#version 300 es
precision highp float;
in vec3 v_nrm;
in vec3 v_world;
in float v_z;
uniform vec3 u_eye;
layout(location = 0) out vec4 o_normal;  // world normal (facing the viewer), linear depth mm
void main() {
  vec3 n = normalize(v_nrm);
  if (dot(n, u_eye - v_world) < 0.0) n = -n;
  o_normal = vec4(n, v_z);
}`;
  // diffuse = the lighting of a white Lambertian surface, each light's intensity being E / pi of a surface facing
  // it (ssskit.scenes.scenefile); no shadows. The surface point: the pixel centre's ray at the linear depth,
  // world = eye + z (ndc.x tan(fov_x / 2) r + ndc.y tan(fov_y / 2) u + f) for the camera's right, up and forward axes.
  const GBUF_FS = `#version 300 es
precision highp float;
uniform highp sampler2D u_geom;
uniform vec2 u_px;       // 2 / W, 2 / H: pixel centre to NDC
uniform vec3 u_cam_r;    // the camera's axes scaled by tan(fov / 2) (right, up) and its forward axis
uniform vec3 u_cam_u;
uniform vec3 u_cam_f;
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
#if ALL_LAYERS   // the layers only the adaptive and transmittance passes read
layout(location = 3) out vec4 o_id;      // profile id (0: no SSS)
layout(location = 4) out vec4 o_light;   // the transmittance pass's inputs: map texel x, y, depth along the light (mm), N . L
#endif
void main() {
  vec4 g = texelFetch(u_geom, ivec2(gl_FragCoord.xy), 0);
  if (g.w <= 0.0) {        // no surface: the cleared values
    o_src = vec4(0.0, 0.0, 0.0, -1.0); o_spec = vec4(0.0); o_albedo = vec4(0.0);
#if ALL_LAYERS
    o_id = vec4(0.0); o_light = vec4(0.0);
#endif
    return;
  }
  vec3 n = g.xyz;
  vec2 ndc = gl_FragCoord.xy * u_px - 1.0;
  vec3 world = u_eye + g.w * (ndc.x * u_cam_r + ndc.y * u_cam_u + u_cam_f);
  vec3 v = normalize(u_eye - world);
  vec3 e = vec3(0.0), s = vec3(0.0);
  for (int i = 0; i < 4; ++i) {
    if (i >= u_nlights) break;
    vec3 l = u_light_dir[i];
    float nl = max(dot(n, l), 0.0);
    e += u_light_rgb[i] * nl;
    vec3 h = normalize(l + v);
    s += u_light_rgb[i] * nl * 0.028 * 6.0 * pow(max(dot(n, h), 0.0), 40.0);  // a glossy coat (F0 = 0.028)
  }
  o_src = vec4(e, u_profile > 0.0 ? g.w : -1.0);
  o_spec = vec4(s, 1.0);
  o_albedo = vec4(u_albedo, 1.0);
#if ALL_LAYERS
  o_id = vec4(u_profile, 0.0, 0.0, 0.0);
  vec3 d = world - u_lo;
  o_light = vec4(dot(d, u_lu) / u_ltexel, dot(d, u_lv) / u_ltexel, -dot(d, u_ll), dot(n, u_ll));
#endif
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
  // Reprojection of the adaptive history after an orbit step: per pixel the motion to where its surface point was
  // in the history's frame (ssskit.screenspace.camera.motion_vectors: pixels, columns and rows from the top) and
  // whether that history may be used. Xie 2020 Sec. 4.1.4 (Eqs. 16-17) restarts a pixel whose fetched history
  // holds no SSS mask (the history's m channel); the page also refuses a fetch whose surface differs, the depth and
  // normal consistency tests of temporal reuse (Schied et al. 2017, SVGF [SKW+17]): the stored linear depth of the
  // fetched pixel within REPROJECT_DEPTH of the point's depth in the history's camera (relative: the depth test of
  // ssskit.screenspace.taa.reprojection_valid at its default tolerance, which tests/view/test_reprojection.py
  // compares), and normals within REPROJECT_COS. The fetch itself is the body's nearest fetch without rejection
  // (Xie Eq. 18).
  const REPROJECT_DEPTH = 0.05, REPROJECT_COS = 0.9;
  const MOTION_FS = `#version 300 es
precision highp float;
uniform highp sampler2D u_geom;        // this frame: world normal, linear depth mm
uniform highp sampler2D u_prev_geom;   // the history's frame
uniform vec2 u_px;
uniform vec3 u_cam_r;
uniform vec3 u_cam_u;
uniform vec3 u_cam_f;
uniform vec3 u_eye;
uniform mat4 u_prev_viewproj;
uniform vec3 u_prev_eye;
uniform vec3 u_prev_f;
layout(location = 0) out vec4 o_motion;
layout(location = 1) out uvec4 o_valid;
void main() {
  vec2 res = 2.0 / u_px;
  vec4 g = texelFetch(u_geom, ivec2(gl_FragCoord.xy), 0);
  o_motion = vec4(0.0);
  o_valid = uvec4(0u);
  if (g.w <= 0.0) return;
  vec2 ndc = gl_FragCoord.xy * u_px - 1.0;
  vec3 world = u_eye + g.w * (ndc.x * u_cam_r + ndc.y * u_cam_u + u_cam_f);
  vec4 c = u_prev_viewproj * vec4(world, 1.0);
  if (c.w <= 0.0) return;
  vec2 prev = (c.xy / c.w * 0.5 + 0.5) * res;   // GL window coordinates in the history's frame
  o_motion = vec4(prev.x - gl_FragCoord.x, gl_FragCoord.y - prev.y, 0.0, 0.0);
  ivec2 pq = ivec2(floor(prev));
  if (any(lessThan(pq, ivec2(0))) || any(greaterThanEqual(pq, ivec2(res)))) return;
  vec4 gp = texelFetch(u_prev_geom, pq, 0);
  float z = dot(world - u_prev_eye, u_prev_f);
  bool ok = gp.w > 0.0 && abs(gp.w - z) <= ${REPROJECT_DEPTH} * z && dot(gp.xyz, g.xyz) >= ${REPROJECT_COS};
  o_valid = uvec4(ok ? 1u : 0u);
}`;
  // TAA of the adaptive pass's output (Karis 2014: an exponential moving average of the frames, here with
  // Xie 2020 Sec. 5's weight alpha_0 = 0.2 for opaque surfaces, the AdaptiveSettings default): ping-pong float
  // targets; after an orbit step the accumulated image is fetched through the same motion and validity as the
  // adaptive history, bilinearly over the texels that hold history (a nearest fetch shifts the image by up to half a
  // pixel), with no neighbourhood clamp (a clamp cuts the Monte Carlo noise's accumulation: Xie Sec. A.1.2's energy
  // loss); a pixel without valid history starts from this frame.
  const TAA_FS = `#version 300 es
precision highp float;
uniform highp sampler2D u_cur;       // this frame's pass output: rgb, alpha < 0 off the mesh
uniform highp sampler2D u_prev;      // the accumulated image: rgb, alpha 1 where it holds history
uniform highp sampler2D u_motion;
uniform highp usampler2D u_valid;
uniform int u_moved;                 // 1: fetch through u_motion where u_valid
uniform int u_reset;                 // 1: a new history
uniform float u_alpha;
out vec4 o_color;
void main() {
  ivec2 q = ivec2(gl_FragCoord.xy);
  vec4 c = texelFetch(u_cur, q, 0);
  if (c.a < 0.0) { o_color = vec4(0.0); return; }
  vec4 h = vec4(0.0);
  if (u_reset == 0) {
    if (u_moved == 0) h = texelFetch(u_prev, q, 0);
    else if (texelFetch(u_valid, q, 0).r != 0u) {
      vec2 mv = texelFetch(u_motion, q, 0).xy;   // columns, rows from the top
      vec2 x = vec2(gl_FragCoord.x + mv.x, gl_FragCoord.y - mv.y) - 0.5;   // texel-centre coordinates
      vec2 f = floor(x), t = x - f;
      ivec2 b = ivec2(f), size = textureSize(u_prev, 0);
      vec4 acc = vec4(0.0);
      for (int k = 0; k < 4; ++k) {
        ivec2 o = ivec2(k & 1, k >> 1), p = b + o;
        if (any(lessThan(p, ivec2(0))) || any(greaterThanEqual(p, size))) continue;
        vec4 v = texelFetch(u_prev, p, 0);
        float w = (o.x == 1 ? t.x : 1.0 - t.x) * (o.y == 1 ? t.y : 1.0 - t.y) * v.a;
        acc += w * vec4(v.rgb, 1.0);
      }
      if (acc.a > 1e-6) h = vec4(acc.rgb / acc.a, 1.0);
    }
  }
  o_color = vec4(h.a > 0.0 ? mix(h.rgb, c.rgb, u_alpha) : c.rgb, 1.0);
}`;
  const TAA_ALPHA = 0.2;
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
  // composite reads (specular, albedo)
  const G = { src: floatTexture(), spec: floatTexture(gl.RGBA16F), albedo: floatTexture(gl.RGBA16F),
    normal: null, id: floatTexture(gl.R32F), light: floatTexture() };
  // the geometry target alternates per frame, so the adaptive pass can read the history's frame's beside this one's
  const geoms = [floatTexture(), floatTexture()].map((t) => ({ tex: t, fb: framebuffer([t], true) }));
  let geomIndex = 0;
  G.normal = geoms[0].tex;
  // the resolve writes the profile id and light-space layers only for a frame whose passes read them
  const gbufFb = [framebuffer([G.src, G.spec, G.albedo], false), framebuffer([G.src, G.spec, G.albedo, G.id, G.light], false)];
  const GBUF_LAYERS = [[G.src, G.spec, G.albedo], [G.src, G.spec, G.albedo, G.id, G.light]];
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
  const motion = floatTexture(gl.RG32F), valid = (() => {
    const t = gl.createTexture();
    gl.bindTexture(gl.TEXTURE_2D, t);
    gl.texStorage2D(gl.TEXTURE_2D, 1, gl.R8UI, W, H);
    for (const k of [gl.TEXTURE_MIN_FILTER, gl.TEXTURE_MAG_FILTER]) gl.texParameteri(gl.TEXTURE_2D, k, gl.NEAREST);
    return t;
  })();
  const motionFb = framebuffer([motion, valid], false), validFb = framebuffer([valid], false);
  const taa = [floatTexture(), floatTexture()], taaFb = taa.map((t) => framebuffer([t], false));
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
  const geom = link(GBUF_VS, GEOM_FS, 'G-buffer (geometry)');
  const gbuf_ = [0, 1].map((all) => link(FULL_VS, GBUF_FS.replace('\n', `\n#define ALL_LAYERS ${all}\n`), 'G-buffer (resolve)'));
  gl.bindVertexArray(vao);
  const positions = decode(S.positions, Float32Array);   // kept: the mesh's screen rectangle (meshRect)
  for (const [name, data] of [['a_pos', positions], ['a_nrm', decode(S.normals, Float32Array)]]) {
    const b = gl.createBuffer();
    gl.bindBuffer(gl.ARRAY_BUFFER, b);
    gl.bufferData(gl.ARRAY_BUFFER, data, gl.STATIC_DRAW);
    const loc = gl.getAttribLocation(geom.p, name);
    gl.enableVertexAttribArray(loc);
    gl.vertexAttribPointer(loc, 3, gl.FLOAT, false, 0, 0);
  }
  const ib = gl.createBuffer();
  gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, ib);
  const indices = decode(S.indices, Uint32Array);   // kept, as the positions: meshRect
  gl.bufferData(gl.ELEMENT_ARRAY_BUFFER, indices, gl.STATIC_DRAW);
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
    return { view, proj, eye: e, right: r, up: u, forward: f, tx, ty, fx: 0.5 * W / tx, fy: 0.5 * H / ty };
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
  let gbufKey = '';     // what the G-buffer holds (render: drawn again only when it changes)
  let shown = G.src;    // what the composite shows: the pass's output, or with the adaptive pass its TAA
  function drawGbuffer(m, mat, all) {
    geomIndex = 1 - geomIndex;
    G.normal = geoms[geomIndex].tex;
    gl.bindFramebuffer(gl.FRAMEBUFFER, geoms[geomIndex].fb);
    gl.viewport(0, 0, W, H);
    gl.enable(gl.DEPTH_TEST);
    gl.clearBufferfv(gl.COLOR, 0, [0, 0, 0, 0]);
    gl.clearBufferfv(gl.DEPTH, 0, [1]);
    gl.useProgram(geom.p);
    gl.uniformMatrix4fv(geom.u.u_view, false, m.view);
    gl.uniformMatrix4fv(geom.u.u_proj, false, m.proj);
    gl.uniform3fv(geom.u.u_eye, m.eye);
    drawMesh();
    const fb = gbufFb[all], gbuf = gbuf_[all];
    gl.bindFramebuffer(gl.FRAMEBUFFER, fb);
    gl.useProgram(gbuf.p);
    bindTextures(gbuf, { u_geom: G.normal });
    gl.uniform2f(gbuf.u.u_px, 2 / W, 2 / H);
    gl.uniform3fv(gbuf.u.u_cam_r, m.right.map((x) => x * m.tx));
    gl.uniform3fv(gbuf.u.u_cam_u, m.up.map((x) => x * m.ty));
    gl.uniform3fv(gbuf.u.u_cam_f, m.forward);
    const L = lights();
    gl.uniform3fv(gbuf.u.u_light_dir, L.dirs);
    gl.uniform3fv(gbuf.u.u_light_rgb, L.rgb);
    gl.uniform1i(gbuf.u.u_nlights, L.n);
    gl.uniform3fv(gbuf.u.u_eye, m.eye);
    gl.uniform3fv(gbuf.u.u_albedo, mat.albedo);
    gl.uniform1f(gbuf.u.u_profile, 1);
    lightUniforms(gbuf, L);
    drawMasked(GBUF_LAYERS[all], [[0, 0, 0, -1], [0, 0, 0, 0], [0, 0, 0, 0], [0, 0, 0, 0], [0, 0, 0, 0]].slice(0, all ? 5 : 3));
  }
  // A full-screen pass on the mesh's pixels only, near enough: per band of BAND rows the span of columns the mesh's
  // triangles that reach the frame cover (their boxes, a pixel's margin), drawn with a scissor box per band; outside
  // the spans every pixel is background, where a pass's output is its target's cleared value. SwiftShader runs the
  // fragment shader on every pixel of a draw, background or not, so the spans are what save the work (a depth-test
  // mask did not: benchmarks/RESULTS.md, "The live viewer"). A target is cleared only where an earlier frame wrote
  // outside this frame's spans.
  const BAND = 32, NB = Math.ceil(H / BAND);
  const FULL = new Int32Array(2 * NB).map((_, i) => (i & 1 ? W : 0));
  let spans = FULL;
  const projected = new Float32Array(positions.length / 3 * 2);
  function meshSpans(m) {
    const P = positions, M = m.view, Q = m.proj, X = projected;
    for (let i = 0, j = 0; i < P.length; i += 3, j += 2) {
      const x = P[i], y = P[i + 1], z = P[i + 2];
      const w = -(M[2] * x + M[6] * y + M[10] * z + M[14]);
      if (w <= 0) return FULL;        // a vertex behind the camera: the whole frame
      X[j] = Q[0] * (M[0] * x + M[4] * y + M[8] * z + M[12]) / w;
      X[j + 1] = Q[5] * (M[1] * x + M[5] * y + M[9] * z + M[13]) / w;
    }
    const out = new Int32Array(2 * NB).map((_, i) => (i & 1 ? 0 : W));   // empty: x0 = W > x1 = 0
    for (let t = 0; t < indices.length; t += 3) {
      const a = 2 * indices[t], b = 2 * indices[t + 1], c = 2 * indices[t + 2];
      const tx0 = Math.min(X[a], X[b], X[c]), tx1 = Math.max(X[a], X[b], X[c]);
      const ty0 = Math.min(X[a + 1], X[b + 1], X[c + 1]), ty1 = Math.max(X[a + 1], X[b + 1], X[c + 1]);
      if (tx1 < -1 || tx0 > 1 || ty1 < -1 || ty0 > 1) continue;   // off the frame
      const px0 = Math.max(0, Math.floor((tx0 + 1) * W / 2) - 1), px1 = Math.min(W, Math.ceil((tx1 + 1) * W / 2) + 1);
      const py0 = Math.max(0, Math.floor((ty0 + 1) * H / 2) - 1), py1 = Math.min(H, Math.ceil((ty1 + 1) * H / 2) + 1);
      for (let k = Math.floor(py0 / BAND), k1 = Math.floor((py1 - 1) / BAND); k <= k1; ++k) {
        if (px0 < out[2 * k]) out[2 * k] = px0;
        if (px1 > out[2 * k + 1]) out[2 * k + 1] = px1;
      }
    }
    return out;
  }
  // the share of the frame the spans cover (the timing's readout)
  const coverage = (sp) => { let n = 0; for (let k = 0; k < NB; ++k) n += Math.max(0, sp[2 * k + 1] - sp[2 * k]) * (Math.min(H, (k + 1) * BAND) - k * BAND); return n / (W * H); };
  // per target (a texture, or 'canvas'): the spans it was last written in (the whole frame at first: zero-initialised)
  const written = new Map();
  // draw into the bound framebuffer, whose colour attachments are `targets`, cleared to `background` (one per
  // attachment) where an earlier frame wrote outside this frame's spans
  function drawMasked(targets, background) {
    gl.enable(gl.SCISSOR_TEST);
    for (let k = 0; k < NB; ++k) {
      const x0 = spans[2 * k], x1 = spans[2 * k + 1], y = k * BAND, h = Math.min(H, y + BAND) - y;
      let c0 = W, c1 = 0;            // the columns an earlier frame wrote outside this band's span
      for (const t of targets) {
        const o = written.has(t) ? written.get(t) : FULL;
        if (o[2 * k] < o[2 * k + 1] && (x0 >= x1 || o[2 * k] < x0 || o[2 * k + 1] > x1)) {
          c0 = Math.min(c0, o[2 * k]); c1 = Math.max(c1, o[2 * k + 1]);
        }
      }
      if (c0 < c1) {
        gl.scissor(c0, y, c1 - c0, h);
        background.forEach((v, i) => gl.clearBufferfv(gl.COLOR, i, v));
      }
      if (x0 < x1) {
        gl.scissor(x0, y, x1 - x0, h);
        gl.drawArrays(gl.TRIANGLES, 0, 3);
      }
    }
    for (const t of targets) written.set(t, spans);
    gl.disable(gl.SCISSOR_TEST);
  }
  // the background of the pass targets: what the passes return off the mesh (the source, (0, 0, 0, -1))
  const NO_SSS = [[0, 0, 0, -1]];
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
    drawMasked([T[target]], NO_SSS);
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
  // Xie 2020 Sec. 4.1: a change of light, material or seed starts a new history; an orbit step reprojects it
  // (MOTION_FS: the estimate and the update then fetch the history through the motion, where valid)
  const ad = { key: '', cur: 0, frame: 0, used: 0, view: null, geom: null, moved: 0, taa: 0, since: 0 };
  // column-major 4x4 product a b
  const mul4 = (a, b) => Array.from({ length: 16 }, (_, i) => [0, 1, 2, 3].reduce((acc, k) => acc + a[4 * k + (i & 3)] * b[4 * (i >> 2) + k], 0));
  function reproject(m) {
    const p = ad.view;
    const prog = passProgram(MOTION_FS, '', 'reprojection');
    gl.useProgram(prog.p);
    bindTextures(prog, { u_geom: G.normal, u_prev_geom: ad.geom });
    gl.uniform2f(prog.u.u_px, 2 / W, 2 / H);
    gl.uniform3fv(prog.u.u_cam_r, m.right.map((x) => x * m.tx));
    gl.uniform3fv(prog.u.u_cam_u, m.up.map((x) => x * m.ty));
    gl.uniform3fv(prog.u.u_cam_f, m.forward);
    gl.uniform3fv(prog.u.u_eye, m.eye);
    gl.uniformMatrix4fv(prog.u.u_prev_viewproj, false, mul4(p.proj, p.view));
    gl.uniform3fv(prog.u.u_prev_eye, p.eye);
    gl.uniform3fv(prog.u.u_prev_f, p.forward);
    gl.bindFramebuffer(gl.FRAMEBUFFER, motionFb);
    gl.drawArrays(gl.TRIANGLES, 0, 3);
  }
  function adaptive(m, mat) {
    const A = mat.adaptive;
    const key = JSON.stringify([state.material, state.light, state.seed, W, H, A.settings]);
    const view = JSON.stringify(cam);
    setUniforms = (prog) => {
      setIf(prog, 'u_size', (l) => gl.uniform2i(l, W, H));
    };
    const moved = key === ad.key && view !== ad.viewKey;
    const reset = key !== ad.key;
    if (key !== ad.key) {            // no history: the estimate on an empty one gives b_min inside the mask
      ad.key = key; ad.cur = 0; ad.frame = 0; ad.moved = 0;
      gl.bindFramebuffer(gl.FRAMEBUFFER, histFb[0]);
      gl.clearBufferfv(gl.COLOR, 0, [0, 0, 0, 0]);
      const est = passProgram(A.estimate, '', 'adaptive estimate');
      gl.useProgram(est.p);
      bindTextures(est, { u_hist: hist[0], u_mask: G.id });
      setUniforms(est);
      gl.bindFramebuffer(gl.FRAMEBUFFER, countFb[0]);
      gl.drawArrays(gl.TRIANGLES, 0, 3);
    } else if (moved) {              // this frame's counts from the history seen from the new view
      reproject(m);
      const est = passProgram(A.estimate_moved, '', 'adaptive estimate (reprojected)');
      gl.useProgram(est.p);
      bindTextures(est, { u_hist: hist[ad.cur], u_mask: G.id, u_motion: motion, u_valid: valid });
      setUniforms(est);
      gl.bindFramebuffer(gl.FRAMEBUFFER, countFb[ad.cur]);
      gl.drawArrays(gl.TRIANGLES, 0, 3);
      ad.moved += 1;
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
    const upd = moved ? passProgram(A.update_moved, '', 'adaptive update (reprojected)') : passProgram(A.update, '', 'adaptive update');
    gl.useProgram(upd.p);
    bindTextures(upd, { u_hist: hist[c], u_mask: G.id, u_rgb: T[1], u_counts: counts[c], u_motion: motion, u_valid: valid });
    setUniforms(upd);
    gl.bindFramebuffer(gl.FRAMEBUFFER, updateFb[1 - c]);
    gl.drawArrays(gl.TRIANGLES, 0, 3);
    ad.used = c; ad.cur = 1 - c; ad.frame += 1;
    ad.since = reset || moved ? 1 : ad.since + 1;   // frames since the last change (the page's loop)
    ad.viewKey = view; ad.view = m; ad.geom = G.normal;   // the history's frame
    const tp = passProgram(TAA_FS, '', 'TAA');
    gl.useProgram(tp.p);
    bindTextures(tp, { u_cur: T[1], u_prev: taa[ad.taa], u_motion: motion, u_valid: valid });
    gl.uniform1i(tp.u.u_moved, moved ? 1 : 0);
    gl.uniform1i(tp.u.u_reset, reset ? 1 : 0);
    gl.uniform1f(tp.u.u_alpha, TAA_ALPHA);
    ad.taa = 1 - ad.taa;
    gl.bindFramebuffer(gl.FRAMEBUFFER, taaFb[ad.taa]);
    drawMasked([taa[ad.taa]], [[0, 0, 0, 0]]);
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
    // the profile id and light-space layers where this frame's passes read them
    const all = state.pass === 'adaptive' || state.transmission ? 1 : 0;
    // The G-buffer is drawn again only when what it shows changed (the view, the light, the albedo, the layers), unless
    // the state says reuse_gbuffer: false (benchmarks/bench_view.py: its frames include the G-buffer pass). The
    // adaptive pass's frames after a change (`frames` on a still view) then cost only the screen-space passes.
    const gkey = JSON.stringify([cam, state.light, mat.albedo, all]);
    timing.gbuffer_reused = state.reuse_gbuffer !== false && gkey === gbufKey;
    if (!timing.gbuffer_reused) timed('gbuffer', () => { spans = meshSpans(m); drawGbuffer(m, mat, all); });
    gbufKey = gkey;
    gl.viewport(0, 0, W, H);
    if (state.pass === 'separable') timed('separable', () => { result = separable(m, mat); });
    else if (state.pass === 'burley' && has('burley')) timed('burley', () => { result = burley(m, mat); });
    else if (state.pass === 'adaptive' && has('adaptive')) {
      if (lastPass !== 'adaptive') ad.key = '';   // switching to the adaptive pass starts a new history
      timed('adaptive', () => { result = adaptive(m, mat); });
    } else result = G.src;
    shown = state.pass === 'adaptive' ? taa[ad.taa] : result;
    lastPass = state.pass;
    const transOn = state.transmission && has('transmission');
    if (transOn) timed('transmission', () => transmission(mat));
    timed('composite', () => {
      gl.bindFramebuffer(gl.FRAMEBUFFER, null);
      gl.useProgram(composite.p);
      bindTextures(composite, { u_src: G.src, u_sss: shown, u_spec: G.spec, u_albedo: G.albedo, u_counts: counts[ad.used],
        u_trans: trans });
      gl.uniform1i(composite.u.u_transmission, transOn ? 1 : 0);
      gl.uniform1i(composite.u.u_split, state.split ? 1 : 0);
      gl.uniform1i(composite.u.u_heat, state.heat && state.pass === 'adaptive' && has('adaptive') ? 1 : 0);
      if (has('adaptive')) gl.uniform2f(composite.u.u_budget, mat.adaptive.b_min, mat.adaptive.b_max);
      gl.uniform1f(composite.u.u_exposure, 1.0);
      drawMasked(['canvas'], [[0.13, 0.13, 0.13, 1]]);   // off the mesh: the composite's background
    });
    sync();
    timing.frame_ms = performance.now() - t0;
    timing.fx = m.fx; timing.fy = m.fy; timing.view = m.view; timing.coverage = coverage(spans);
    frames += 1;
    drawn = { material: state.material, transmission: transOn, frame: frames };
    const lines = Object.entries(timing.passes).map(([k, v]) => `${k.padEnd(10)} ${v.toFixed(2)} ms`);
    if (timing.gbuffer_reused) lines.unshift('gbuffer    reused (unchanged)');
    $('stats').textContent = `${W}x${H}, ${S.triangles} triangles\nframe ${timing.frame_ms.toFixed(1)} ms (` +
      `${(1000 / timing.frame_ms).toFixed(1)} fps, wall time to a finished readback)\n` + lines.join('\n') + `\nper pass: ${timing.mode}` +
      (S.about && S.about.attribution ? `\n${S.about.attribution}` : '');
    return JSON.parse(JSON.stringify(timing));
  }

  let frames = 0, dirty = true;
  let drawn = null;   // what the last frame showed: its material, whether with the transmittance pass
  function loop() {
    if (state.pass === 'adaptive' && state.auto && ad.since < state.frames) dirty = true;
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
    // a float target as base64 float32 RGBA, GL's rows (bottom first): src, spec, albedo, normal, id, light, result,
    // history (the adaptive history after the last frame), taa (the adaptive pass's accumulated image, alpha 1 on
    // the mesh), motion (the last reprojection's); id and light are
    // those of the last frame with the adaptive or transmittance pass (the frames that write them)
    read(name) {
      const tex = name === 'result' ? result : name === 'history' ? hist[ad.cur] : name === 'transmission' ? trans
        : name === 'motion' ? motion : name === 'taa' ? taa[ad.taa] : G[name];
      return toBase64(new Uint8Array(readFloat(tex).buffer));
    },
    // the sample counts the last adaptive frame used (used) or the next frame's (next), base64 int32, GL's rows
    // after an orbit step with the adaptive pass: the motion (base64 float32 RG as RGBA, GL's rows) and the validity
    // image (base64 uint32, GL's rows; 1: the history was reused), and how many frames reprojected a history
    readValid() { return readChannel(validFb, W, H, Uint32Array, gl.RGBA_INTEGER, gl.UNSIGNED_INT); },
    reprojected: () => ad.moved,
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
