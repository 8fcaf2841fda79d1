// The Babylon.js client of ssskit's tests: renders ssskit's Babylon export (a module served beside this page)
// on a slab with a straight shadow edge and returns the linear float pixels after
// Babylon's subsurface pass. Everything is local: @babylonjs/core from ./node_modules (npm, pinned).
import * as BABYLON from "./node_modules/@babylonjs/core/index.js";

// The last post-process packs one channel of its (float) input into two bytes of the canvas (16 bits, of
// [0, 1]): the subsurface pass writes into that input, so the canvas gives its linear value exactly.
BABYLON.ShaderStore.ShadersStore["ssskitPackFragmentShader"] = `
precision highp float;
varying vec2 vUV;
uniform sampler2D textureSampler;
uniform sampler2D irradianceSampler;
uniform sampler2D depthSampler;
uniform float channel;
uniform float source;
uniform vec2 range;
void main(void) {
  // source 0: the subsurface pass's output; 1: the pre-pass irradiance (alpha: the profile index / 255);
  // 2: the pre-pass depth (view z, scene units), mapped from range to [0, 1]
  vec4 c = source < 0.5 ? texture2D(textureSampler, vUV)
         : (source < 1.5 ? texture2D(irradianceSampler, vUV) : texture2D(depthSampler, vUV));
  float x = channel < 0.5 ? c.r : (channel < 1.5 ? c.g : (channel < 2.5 ? c.b : c.a));
  x = (x - range.x) / (range.y - range.x);
  float q = floor(clamp(x, 0.0, 1.0) * 65535.0 + 0.5);
  float hi = floor(q / 256.0);
  gl_FragColor = vec4(hi / 255.0, (q - 256.0 * hi) / 255.0, x > 1.0 ? 1.0 : 0.0, 1.0);
}`;

window.ssskitRender = async (o) => {
  const canvas = document.getElementById("c");
  canvas.width = o.width; canvas.height = o.height;
  canvas.style.width = `${o.width}px`; canvas.style.height = `${o.height}px`;
  const engine = new BABYLON.Engine(canvas, false, { preserveDrawingBuffer: true, antialias: false });
  if (engine.webGLVersion < 2) throw new Error("WebGL2 needed");
  const scene = new BABYLON.Scene(engine);
  scene.clearColor = new BABYLON.Color4(0, 0, 0, 1);
  scene.ambientColor = new BABYLON.Color3(0, 0, 0);
  scene.imageProcessingConfiguration.isEnabled = false;
  const ext = o.extent;  // half-width of the view in scene units
  // a perspective camera far above, straight down, with a narrow field of view: Babylon's subsurface pass
  // takes the pixel size from camera.fov (subSurfaceScatteringPostProcess: viewportSize), so no ortho camera
  const aspect = o.height / o.width;
  const far = 50 * ext;
  const cam = new BABYLON.FreeCamera("cam", new BABYLON.Vector3(0, far, 0), scene);
  cam.upVector = new BABYLON.Vector3(0, 0, 1);
  cam.setTarget(BABYLON.Vector3.Zero());
  cam.fov = 2 * Math.atan(ext * aspect / far);
  cam.minZ = far - 3 * ext; cam.maxZ = far + 3 * ext;
  // the sun at 45 degrees, coming from -x; a blocker over x < -1.5 ext at height 1.5 ext (outside the view) casts
  // the edge at x = 0; the slab's irradiance is the same everywhere on the lit side
  const light = new BABYLON.DirectionalLight("sun", new BABYLON.Vector3(1, -1, 0), scene);
  light.intensity = o.intensity;
  light.position = new BABYLON.Vector3(-10 * ext, 10 * ext, 0);
  light.shadowMinZ = 0.01 * ext;  // else the camera's near and far planes, which miss the scene from the light
  light.shadowMaxZ = 40 * ext;
  let receiver;
  if (o.shape === "sphere") {  // a sphere of radius o.radius at the origin: the terminator from N.L, no shadow map
    receiver = BABYLON.MeshBuilder.CreateSphere("ball", { diameter: 2 * o.radius, segments: o.segments || 96 }, scene);
  } else {
    receiver = BABYLON.MeshBuilder.CreateGround("slab", { width: 6 * ext, height: 6 * ext, subdivisions: 1 }, scene);
    const blocker = BABYLON.MeshBuilder.CreateGround("blocker", { width: 4 * ext, height: 8 * ext }, scene);
    blocker.position = new BABYLON.Vector3(-1.5 * ext - 2 * ext, 1.5 * ext, 0);
    blocker.sideOrientation = BABYLON.Mesh.DOUBLESIDE;
    const sg = new BABYLON.ShadowGenerator(4096, light);
    sg.filter = BABYLON.ShadowGenerator.FILTER_NONE;
    sg.bias = 0; sg.normalBias = 0;
    sg.addShadowCaster(blocker);
    receiver.receiveShadows = true;
  }
  let mat;
  {
    const mod = await import(o.module + "?v=" + Math.random());
    const ssskit = mod.SSSKIT;
    if (o.white) {  // the irradiance reference through the same passes: albedo 1, a profile 0.01 mm wide, sampled
      // over 0.01 mm (colour 1 with metersPerUnit 100 x the scene's: module docstring of ssskit.export.babylon)
      o.override = { albedo: [1, 1, 1], color: [1, 1, 1], metersPerUnit: 100 * ssskit.unit_m };
      o.variant = "plain";
    }
    if (o.override) {  // the colour-question renders: the same export with another profile colour or scale
      const v = ssskit.variants[o.variant];
      if (o.override.color) v.diffusionProfile[o.material] = o.override.color;
      if (o.override.metersPerUnit) v.metersPerUnit = o.override.metersPerUnit;
      if (o.override.albedo) ssskit.materials[o.material].albedoColor = o.override.albedo;
    }
    for (const name of Object.keys(ssskit.materials)) if (name !== o.material) delete ssskit.materials[name];
    mat = mod.applySsskit(BABYLON, scene, {}, o.variant)[o.material];
    // no composition pass: its gamma and its 8-bit input would quantise what the subsurface pass wrote
    scene.prePassRenderer.disableGammaTransform = true;
  }
  mat.environmentIntensity = 0;
  receiver.material = mat;
  let channel = 0;
  const pack = new BABYLON.PostProcess("ssskitPack", "ssskitPack", ["channel", "source", "range"],
                                       ["irradianceSampler", "depthSampler"], 1.0, cam,
                                       BABYLON.Texture.NEAREST_SAMPLINGMODE, engine, false, null,
                                       BABYLON.Constants.TEXTURETYPE_FLOAT);
  let source = 0, range = [0, 1];
  pack.onApply = (effect) => {
    effect.setFloat("channel", channel);
    effect.setFloat("source", source);
    effect.setFloat2("range", range[0], range[1]);
    const pp = scene.prePassRenderer;  // the textures Babylon's subsurface pass reads (its getIndex(0) and (5))
    effect.setTexture("irradianceSampler", pp.getRenderTarget().textures[pp.getIndex(0)]);
    effect.setTexture("depthSampler", pp.getRenderTarget().textures[pp.getIndex(5)]);
  };
  // render until every effect has compiled (the pre-pass recompiles the materials), then a few frames more
  for (let i = 0; i < 600 && !(scene.isReady() && mat.isReady(receiver)); i++) {
    scene.render();
    await new Promise(r => setTimeout(r, 20));
  }
  for (let i = 0; i < (o.frames || 3); i++) { scene.render(); await new Promise(r => setTimeout(r, 20)); }
  let clipped = 0;
  const read = async (src, chans, lo, hi) => {  // chans channels of one source, 16 bits each of [lo, hi]
    const out = new Float32Array(o.width * o.height * chans);
    source = src; range = [lo, hi];
    for (channel = 0; channel < chans; channel++) {
      scene.render();
      const bytes = await engine.readPixels(0, 0, o.width, o.height);
      for (let i = 0; i < o.width * o.height; i++) {
        out[chans * i + channel] = lo + (hi - lo) * (256 * bytes[4 * i] + bytes[4 * i + 1]) / 65535;
        if (src === 0) clipped += bytes[4 * i + 2] > 127 ? 1 : 0;
      }
    }
    return out;
  };
  const px = await read(0, 3, 0, 1);
  let gbuffer = null;
  if (o.gbuffer) {  // what the subsurface pass read: irradiance (over sqrt(albedo), clamped), profile, view z
    const zlo = far - 3 * ext, zhi = far + 3 * ext;
    gbuffer = { irradiance: Array.from(await read(1, 4, 0, 1)), depth: Array.from(await read(2, 1, zlo, zhi)),
                depthRange: [zlo, zhi], fov: cam.fov };
  }
  const info = { postProcesses: cam._postProcesses.filter(p => p).map(p => p.name),
                 profiles: scene.subSurfaceConfiguration ? scene.subSurfaceConfiguration.ssDiffusionS : null,
                 filterRadii: scene.subSurfaceConfiguration ? scene.subSurfaceConfiguration.ssFilterRadii : null,
                 metersPerUnit: scene.subSurfaceConfiguration ? scene.subSurfaceConfiguration.metersPerUnit : null,
                 clipped,
                 version: BABYLON.Engine.Version, webgl: engine.webGLVersion };
  engine.dispose();
  return { pixels: Array.from(px), info, gbuffer };
};
window.ssskitReady = true;
