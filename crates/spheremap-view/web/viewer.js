// spheremap view: a mesh lit by a sphere map in WebGL2, the sphere map regenerated on the GPU
// for the current camera from a world-frame lat-long every frame (or frozen).
//
// Conventions are spheremap's (docs/viewer.md):
// * camera: gluLookAt(eye, target, up) and gluPerspective(fovy, W/H, near, far), near and far
//   from the mesh's bounding sphere as `spheremap render` frames them;
// * the sphere map is kept GL-native (texel row 0 at t = 0, the bottom) and looked up at the
//   (s, t) of GL_SPHERE_MAP texgen; images (the MatCap) are uploaded row 0 first and looked up
//   at (u, 1 − v);
// * display: x · 2^exposure, the tone-map operator, the sRGB transfer, as `render` writes PNGs.
//
// URL parameters: mode, eye=X,Y,Z, target=X,Y,Z, up=X,Y,Z, fovy, size=W,H, exposure, tonemap,
// variant, freeze (0/1), smsize (the sphere map's size), background (env/black), normalize (0/1).
// window.spheremap.ready resolves when the frame for the current parameters has been drawn.
"use strict";

(function () {
  const $ = (id) => document.getElementById(id);
  const errorBox = $("error");
  const statusBox = $("status");

  // ---------------------------------------------------------------- small linear algebra (f64)
  const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
  const add = (a, b) => [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
  const scale = (a, k) => [a[0] * k, a[1] * k, a[2] * k];
  const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
  const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
  const len = (a) => Math.sqrt(dot(a, a));
  const unit = (a) => scale(a, 1 / len(a));

  // Rodrigues: v turned by `deg` about the unit axis k.
  function rotate(v, k, deg) {
    const t = (deg * Math.PI) / 180, c = Math.cos(t), s = Math.sin(t);
    return add(add(scale(v, c), scale(cross(k, v), s)), scale(k, dot(k, v) * (1 - c)));
  }

  // gluLookAt: rows s, u, −f and the translation; returned as column-major 4×4 and the 3×3
  // eye → world rotation (columns s, u, −f).
  function lookAt(eye, target, up) {
    const f = unit(sub(target, eye));
    const s = unit(cross(f, up));
    const u = cross(s, f);
    const m = [s, u, scale(f, -1)];
    const t = m.map((r) => -dot(r, eye));
    const mv = new Float32Array(16);
    for (let i = 0; i < 3; i++) {
      for (let j = 0; j < 3; j++) mv[j * 4 + i] = m[i][j];
      mv[12 + i] = t[i];
    }
    mv[15] = 1;
    const eyeToWorld = new Float32Array([s[0], s[1], s[2], u[0], u[1], u[2], -f[0], -f[1], -f[2]]);
    const normalMatrix = new Float32Array([m[0][0], m[1][0], m[2][0], m[0][1], m[1][1], m[2][1], m[0][2], m[1][2], m[2][2]]);
    return { mv, eyeToWorld, normalMatrix };
  }

  function perspective(fovy, aspect, near, far) {
    const c = 1 / Math.tan(((fovy * Math.PI) / 180) / 2);
    const p = new Float32Array(16);
    p[0] = c / aspect;
    p[5] = c;
    p[10] = (far + near) / (near - far);
    p[11] = -1;
    p[14] = (2 * far * near) / (near - far);
    return p;
  }

  // ---------------------------------------------------------------- state and URL parameters
  const params = new URLSearchParams(location.search);
  const vec3Param = (name) => {
    const v = params.get(name);
    if (v === null) return null;
    const a = v.split(",").map(Number);
    if (a.length !== 3 || !a.every(Number.isFinite)) throw new Error(`URL parameter ${name}=${v}: expected X,Y,Z`);
    return a;
  };
  const numParam = (name, dflt) => {
    const v = params.get(name);
    if (v === null) return dflt;
    const x = Number(v);
    if (!Number.isFinite(x)) throw new Error(`URL parameter ${name}=${v}: expected a number`);
    return x;
  };
  const boolParam = (name, dflt) => {
    const v = params.get(name);
    if (v === null) return dflt;
    if (!["0", "1", "true", "false"].includes(v)) throw new Error(`URL parameter ${name}=${v}: expected 0 or 1`);
    return v === "1" || v === "true";
  };

  const state = {
    mode: "per-pixel", variant: "classic", tonemap: "clamp", exposure: 0, fovy: 40,
    eye: null, target: null, up: [0, 1, 0], size: null, freeze: false, smsize: 512,
    background: true, normalize: true, supersample: 2,
  };
  // The camera the sphere map was frozen for (eye → world rotation).
  let frozenRotation = null;

  let scene = null; // data/scene.json
  let gl = null, pgl = null; // the view's and the preview's contexts
  let view = null, preview = null; // their GPU resources
  let dirty = true;
  let readyResolve = null;
  let firstFrameMs = null;

  const api = {
    ready: null,
    state: () => JSON.parse(JSON.stringify({ ...state, frozen: frozenRotation !== null })),
    set: (changes) => { applyChanges(changes); return api.ready; },
    benchmark: (frames, regenerate = true) => benchmark(frames, regenerate),
    timing: {},
    scene: () => scene,
    sphereMap: () => sphereMap(),
    subpixelBits: null,
    version: 0,
  };
  window.spheremap = api;

  function newReady() {
    api.ready = new Promise((resolve, reject) => { readyResolve = resolve; api._reject = reject; });
    api.ready.catch(() => {}); // a page error is shown, not thrown at nobody
  }
  newReady();

  function fail(message) {
    errorBox.textContent = message;
    if (api._reject) api._reject(new Error(message));
  }

  function showError(message) {
    errorBox.textContent = message.split("\n")[0];
  }

  // ---------------------------------------------------------------- shaders
  const HEADER = "#version 300 es\nprecision highp float;\nprecision highp int;\n";

  // The display transform of `render`: exposure, operator, sRGB.
  const DISPLAY = `
uniform float u_exposure;
uniform int u_tonemap; // 0 clamp, 1 reinhard, 2 aces
float tone(float x) {
  x = max(x, 0.0);
  if (u_tonemap == 1) return x / (1.0 + x);
  if (u_tonemap == 2) return clamp((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0);
  return min(x, 1.0);
}
float srgb(float v) {
  v = clamp(v, 0.0, 1.0);
  return v <= 0.0031308 ? 12.92 * v : 1.055 * pow(v, 1.0 / 2.4) - 0.055;
}
vec3 display(vec3 c) {
  float k = exp2(u_exposure);
  return vec3(srgb(tone(c.r * k)), srgb(tone(c.g * k)), srgb(tone(c.b * k)));
}`;

  // A direction in the world → the environment (a lat-long in the default preset).
  const ENV = `
uniform sampler2D u_env;
uniform vec2 u_envSize;
uniform float u_envMaxLod;
const float PI = 3.141592653589793;
vec2 latlongUv(vec3 w) {
  return vec2(fract(0.5 + atan(w.z, w.x) / (2.0 * PI)), acos(clamp(w.y, -1.0, 1.0)) / PI);
}
// omega: the solid angle the lookup stands for; the level whose texels are that large.
vec3 envLookup(vec3 w, float omega) {
  w = normalize(w);
  float sinTheta = max(sqrt(max(0.0, 1.0 - w.y * w.y)), 1e-4);
  float texel = (2.0 * PI / u_envSize.x) * (PI / u_envSize.y) * sinTheta;
  float lod = clamp(0.5 * log2(omega / texel), 0.0, u_envMaxLod);
  return textureLod(u_env, latlongUv(w), lod).rgb;
}`;

  const QUAD_VS = `${HEADER}
out vec2 v_ndc;
void main() {
  vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2)) * 2.0 - 1.0;
  v_ndc = p;
  gl_Position = vec4(p, 1.0, 1.0);
}`;

  // The sphere map of the view whose eye → world rotation is u_eyeToWorld: texel (s, t) shows
  // the eye-space direction r = (2 n_z x, 2 n_z y, 2 n_z² − 1), (x, y) = 2 (s, t) − 1; off the
  // disc, the gutter of spheremap's conversions (the radial mirror image across the rim).
  // Each texel covers 16/S² sr (the sphere map's solid angle is even in (s, t)).
  const GEN_FS = `${HEADER}${ENV}${DISPLAY}
uniform mat3 u_eyeToWorld;
uniform float u_size;
uniform bool u_toScreen;
uniform int u_supersample;
in vec2 v_ndc;
out vec4 o;
vec3 texelDir(vec2 st) {
  vec2 ab = 2.0 * st - 1.0;
  float rho = length(ab);
  if (rho > 1.0) ab *= clamp(2.0 - rho, 0.0, 1.0 - 1e-6) / rho;
  float nz = sqrt(max(0.0, 1.0 - dot(ab, ab)));
  return vec3(2.0 * nz * ab, 2.0 * nz * nz - 1.0);
}
void main() {
  // The box filter over the texel's footprint, as spheremap's conversions: K × K points.
  vec3 c = vec3(0.0);
  float k = float(u_supersample);
  float omega = 16.0 / (u_size * u_size * k * k);
  for (int j = 0; j < u_supersample; j++) {
    for (int i = 0; i < u_supersample; i++) {
      vec2 st = (gl_FragCoord.xy - 0.5 + (vec2(i, j) + 0.5) / k) / u_size;
      c += envLookup(u_eyeToWorld * texelDir(st), omega);
    }
  }
  c /= k * k;
  o = u_toScreen ? vec4(display(c), 1.0) : vec4(c, 1.0);
}`;

  // The environment behind the mesh: the view ray of each pixel.
  const BG_FS = `${HEADER}${ENV}${DISPLAY}
uniform mat3 u_eyeToWorld;
uniform vec2 u_tanHalf; // tan of half the field of view, x and y
uniform float u_pixelOmega;
in vec2 v_ndc;
out vec4 o;
void main() {
  vec3 d = vec3(v_ndc * u_tanHalf, -1.0);
  float l2 = dot(d, d);
  o = vec4(display(envLookup(u_eyeToWorld * d, u_pixelOmega / (l2 * sqrt(l2)))), 1.0);
}`;

  function meshVS(glsl) {
    return `${HEADER}
${glsl.texgen}
in vec3 a_pos;
in vec3 a_normal;
uniform mat4 u_mv;
uniform mat4 u_proj;
uniform mat3 u_normalMatrix;
uniform bool u_normalize;
out vec3 v_eyePos;
out vec3 v_eyeNormal;
out vec2 v_st;
void main() {
  vec4 e = u_mv * vec4(a_pos, 1.0);
  vec3 n = u_normalMatrix * a_normal;
  if (u_normalize) n = normalize(n);
  vec2 st = sphere_map_texgen(e.xyz, n);
  // A vertex whose reflection is straight back at the viewer: (1/2, 1/2), as legacy Mesa.
  if (any(isnan(st)) || any(isinf(st))) st = vec2(0.5);
  v_eyePos = e.xyz;
  v_eyeNormal = n;
  v_st = st;
  gl_Position = u_proj * e;
}`;
  }

  function meshFS(glsl) {
    return `${HEADER}
${glsl.lookup}
${glsl.matcap}
${DISPLAY}
uniform sampler2D u_sphere;   // GL-native: sampled at (s, t)
uniform sampler2D u_matcap;   // row 0 first: sampled at (u, 1 - v)
uniform bool u_hasMatcap;
uniform int u_mode;           // 0 per-vertex, 1 per-pixel, 2 matcap, 3 normals, 4 error
uniform int u_variant;        // 0 classic, 1 threejs, 2 perspective
uniform vec3 u_heat[6];
uniform float u_heatMax;
in vec3 v_eyePos;
in vec3 v_eyeNormal;
in vec2 v_st;
out vec4 o;
vec3 sphereDir(vec2 st) {
  vec2 ab = 2.0 * st - 1.0;
  float q = dot(ab, ab);
  if (q > 1.0) { ab /= sqrt(q); q = 1.0; }
  float nz = sqrt(1.0 - q);
  return vec3(2.0 * nz * ab, 2.0 * nz * nz - 1.0);
}
// GL_LINEAR with clamp to edge, with full-precision weights (a GPU's filter unit may quantise
// them to 8 bits, which shows at the sharp HDR edges of a sphere map's rim): the same formula as
// render's sampler. flip: the image's row 0 is t = 1 (an image file) rather than t = 0 (GL).
vec3 linear(sampler2D tex, vec2 st, bool flip) {
  ivec2 n = textureSize(tex, 0);
  if (flip) st.y = 1.0 - st.y;
  vec2 u = st * vec2(n) - 0.5;
  vec2 i0 = floor(u);
  vec2 f = u - i0;
  ivec2 a = clamp(ivec2(i0), ivec2(0), n - 1), b = clamp(ivec2(i0) + 1, ivec2(0), n - 1);
  return mix(mix(texelFetch(tex, ivec2(a.x, a.y), 0).rgb, texelFetch(tex, ivec2(b.x, a.y), 0).rgb, f.x),
             mix(texelFetch(tex, ivec2(a.x, b.y), 0).rgb, texelFetch(tex, ivec2(b.x, b.y), 0).rgb, f.x), f.y);
}
vec3 heat(float x) {
  float f = clamp(x, 0.0, 1.0) * 5.0;
  int i = min(int(floor(f)), 4);
  return mix(u_heat[i], u_heat[i + 1], f - float(i));
}
void main() {
  if (u_mode == 0) {
    o = vec4(display(linear(u_sphere, v_st, false)), 1.0);
  } else if (u_mode == 1) {
    vec3 r = reflect(normalize(v_eyePos), normalize(v_eyeNormal));
    o = vec4(display(linear(u_sphere, sphere_map_st(r), false)), 1.0);
  } else if (u_mode == 2) {
    vec2 uv = u_variant == 1 ? matcap_threejs(v_eyeNormal, v_eyePos)
            : u_variant == 2 ? matcap_perspective(v_eyeNormal, v_eyePos)
            : matcap_classic(v_eyeNormal);
    vec3 c = u_hasMatcap ? linear(u_matcap, uv, true) : linear(u_sphere, uv, false);
    o = vec4(display(c), 1.0);
  } else if (u_mode == 3) {
    o = vec4(display(normalize(v_eyeNormal) * 0.5 + 0.5), 1.0);
  } else {
    vec3 r = normalize(reflect(normalize(v_eyePos), normalize(v_eyeNormal)));
    float c = clamp(dot(normalize(sphereDir(v_st)), r), -1.0, 1.0);
    o = vec4(heat(degrees(acos(c)) / u_heatMax), 1.0);
  }
}`;
  }

  function compile(g, vs, fs) {
    const prog = g.createProgram();
    for (const [type, src] of [[g.VERTEX_SHADER, vs], [g.FRAGMENT_SHADER, fs]]) {
      const sh = g.createShader(type);
      g.shaderSource(sh, src);
      g.compileShader(sh);
      if (!g.getShaderParameter(sh, g.COMPILE_STATUS)) throw new Error("shader: " + g.getShaderInfoLog(sh));
      g.attachShader(prog, sh);
    }
    g.bindAttribLocation(prog, 0, "a_pos");
    g.bindAttribLocation(prog, 1, "a_normal");
    g.linkProgram(prog);
    if (!g.getProgramParameter(prog, g.LINK_STATUS)) throw new Error("link: " + g.getProgramInfoLog(prog));
    const uniforms = {};
    const n = g.getProgramParameter(prog, g.ACTIVE_UNIFORMS);
    for (let i = 0; i < n; i++) {
      const name = g.getActiveUniform(prog, i).name.replace(/\[0\]$/, "");
      uniforms[name] = g.getUniformLocation(prog, name);
    }
    return { prog, u: uniforms };
  }

  // ---------------------------------------------------------------- data
  async function fetchBytes(url) {
    const r = await fetch(url, { cache: "no-store" });
    if (!r.ok) throw new Error(`${url}: HTTP ${r.status}`);
    return r.arrayBuffer();
  }

  async function loadData() {
    const r = await fetch("data/scene.json", { cache: "no-store" });
    if (!r.ok) throw new Error(`data/scene.json: HTTP ${r.status}`);
    const s = await r.json();
    const [mesh, env, matcap] = await Promise.all([
      fetchBytes("data/mesh.bin"),
      s.env ? fetchBytes("data/env.bin") : null,
      s.matcap ? fetchBytes("data/matcap.bin") : null,
    ]);
    return { s, mesh, env, matcap };
  }

  function uploadHalfTexture(g, tex, info, bytes, mipmaps) {
    g.bindTexture(g.TEXTURE_2D, tex);
    g.pixelStorei(g.UNPACK_ALIGNMENT, 1);
    info.levels.forEach(([w, h, off], i) => {
      g.texImage2D(g.TEXTURE_2D, i, g.RGBA16F, w, h, 0, g.RGBA, g.HALF_FLOAT, new Uint16Array(bytes, off, w * h * 4));
    });
    g.texParameteri(g.TEXTURE_2D, g.TEXTURE_MAX_LEVEL, info.levels.length - 1);
    g.texParameteri(g.TEXTURE_2D, g.TEXTURE_MIN_FILTER, mipmaps ? g.LINEAR_MIPMAP_LINEAR : g.LINEAR);
    g.texParameteri(g.TEXTURE_2D, g.TEXTURE_MAG_FILTER, g.LINEAR);
    g.texParameteri(g.TEXTURE_2D, g.TEXTURE_WRAP_S, mipmaps ? g.REPEAT : g.CLAMP_TO_EDGE);
    g.texParameteri(g.TEXTURE_2D, g.TEXTURE_WRAP_T, g.CLAMP_TO_EDGE);
  }

  function black(g) {
    const t = g.createTexture();
    g.bindTexture(g.TEXTURE_2D, t);
    g.texImage2D(g.TEXTURE_2D, 0, g.RGBA16F, 1, 1, 0, g.RGBA, g.HALF_FLOAT, new Uint16Array(4));
    return t;
  }

  // GPU resources of one context: the environment and the sphere-map generator.
  function makeGen(g, d) {
    const res = { gen: compile(g, QUAD_VS, GEN_FS), vao: g.createVertexArray(), env: null, envInfo: d.s.env };
    if (d.s.env) {
      res.env = g.createTexture();
      uploadHalfTexture(g, res.env, d.s.env, d.env, true);
    } else {
      res.env = black(g);
      res.envInfo = { levels: [[1, 1, 0]] };
    }
    return res;
  }

  function setEnvUniforms(g, p, res) {
    const [w, h] = res.envInfo.levels[0];
    g.activeTexture(g.TEXTURE0);
    g.bindTexture(g.TEXTURE_2D, res.env);
    g.uniform1i(p.u.u_env, 0);
    g.uniform2f(p.u.u_envSize, w, h);
    g.uniform1f(p.u.u_envMaxLod, res.envInfo.levels.length - 1);
  }

  function setDisplayUniforms(g, p) {
    if (p.u.u_exposure) g.uniform1f(p.u.u_exposure, state.exposure);
    if (p.u.u_tonemap) g.uniform1i(p.u.u_tonemap, Math.max(0, scene.tonemaps.indexOf(state.tonemap)));
  }

  function buildView(d) {
    const g = gl;
    const res = makeGen(g, d);
    res.bg = compile(g, QUAD_VS, BG_FS);
    res.mesh = compile(g, meshVS(d.s.glsl), meshFS(d.s.glsl));
    // The mesh.
    const nv = d.s.mesh.vertices, nt = d.s.mesh.triangles;
    res.meshVao = g.createVertexArray();
    g.bindVertexArray(res.meshVao);
    const pos = g.createBuffer();
    g.bindBuffer(g.ARRAY_BUFFER, pos);
    g.bufferData(g.ARRAY_BUFFER, new Float32Array(d.mesh, 0, nv * 6), g.STATIC_DRAW);
    g.enableVertexAttribArray(0);
    g.vertexAttribPointer(0, 3, g.FLOAT, false, 0, 0);
    g.enableVertexAttribArray(1);
    g.vertexAttribPointer(1, 3, g.FLOAT, false, 0, nv * 12);
    const idx = g.createBuffer();
    g.bindBuffer(g.ELEMENT_ARRAY_BUFFER, idx);
    g.bufferData(g.ELEMENT_ARRAY_BUFFER, new Uint32Array(d.mesh, nv * 24, nt * 3), g.STATIC_DRAW);
    g.bindVertexArray(null);
    res.count = nt * 3;
    // The sphere map's render target.
    res.sphere = g.createTexture();
    res.fbo = g.createFramebuffer();
    res.sphereSize = 0;
    res.matcap = null;
    if (d.s.matcap) {
      res.matcap = g.createTexture();
      uploadHalfTexture(g, res.matcap, d.s.matcap, d.matcap, false);
    } else {
      res.matcap = black(g);
    }
    return res;
  }

  function sphereTarget(res, size) {
    const g = gl;
    if (res.sphereSize === size) return;
    g.bindTexture(g.TEXTURE_2D, res.sphere);
    g.texImage2D(g.TEXTURE_2D, 0, g.RGBA16F, size, size, 0, g.RGBA, g.HALF_FLOAT, null);
    // GL_LINEAR, no mipmaps, clamp to edge: as `render` samples a sphere map.
    g.texParameteri(g.TEXTURE_2D, g.TEXTURE_MIN_FILTER, g.LINEAR);
    g.texParameteri(g.TEXTURE_2D, g.TEXTURE_MAG_FILTER, g.LINEAR);
    g.texParameteri(g.TEXTURE_2D, g.TEXTURE_WRAP_S, g.CLAMP_TO_EDGE);
    g.texParameteri(g.TEXTURE_2D, g.TEXTURE_WRAP_T, g.CLAMP_TO_EDGE);
    g.bindFramebuffer(g.FRAMEBUFFER, res.fbo);
    g.framebufferTexture2D(g.FRAMEBUFFER, g.COLOR_ATTACHMENT0, g.TEXTURE_2D, res.sphere, 0);
    const st = g.checkFramebufferStatus(g.FRAMEBUFFER);
    g.bindFramebuffer(g.FRAMEBUFFER, null);
    if (st !== g.FRAMEBUFFER_COMPLETE) throw new Error("this browser cannot render to half-float textures (EXT_color_buffer_float)");
    res.sphereSize = size;
    res.generated = null;
  }

  function generate(g, res, rotation, size, toScreen) {
    const p = res.gen;
    g.useProgram(p.prog);
    setEnvUniforms(g, p, res);
    setDisplayUniforms(g, p);
    g.uniformMatrix3fv(p.u.u_eyeToWorld, false, rotation);
    g.uniform1f(p.u.u_size, size);
    g.uniform1i(p.u.u_toScreen, toScreen ? 1 : 0);
    g.uniform1i(p.u.u_supersample, state.supersample);
    g.viewport(0, 0, size, size);
    g.disable(g.DEPTH_TEST);
    g.bindVertexArray(res.vao);
    g.drawArrays(g.TRIANGLES, 0, 3);
  }

  // ---------------------------------------------------------------- the camera
  function camera() {
    const m = scene.mesh;
    const canvas = $("view");
    const W = canvas.width, H = canvas.height;
    if (!state.target) state.target = m.centre.slice();
    const target = state.target;
    let eye = state.eye;
    if (!eye) {
      const half = ((state.fovy * Math.PI) / 180) / 2;
      const halfMin = W >= H ? half : Math.atan((Math.tan(half) * W) / H);
      eye = [target[0], target[1], target[2] + (1.1 * m.radius) / Math.sin(halfMin)];
      state.eye = eye;
    }
    const d = len(sub(eye, m.centre));
    const near = Math.max((d - m.radius) * 0.9, d * 1e-3);
    const far = (d + m.radius) * 1.1;
    const la = lookAt(eye, target, state.up);
    return { ...la, proj: perspective(state.fovy, W / H, near, far), W, H };
  }

  // ---------------------------------------------------------------- drawing
  function draw() {
    const g = gl, res = view;
    const cam = camera();
    const size = state.smsize;
    sphereTarget(res, size);
    const rotation = state.freeze && frozenRotation ? frozenRotation : cam.eyeToWorld;
    if (state.freeze && !frozenRotation) frozenRotation = cam.eyeToWorld;
    // The sphere map: regenerated every frame unless frozen (and already made).
    if (!(state.freeze && res.generated === "frozen")) {
      g.bindFramebuffer(g.FRAMEBUFFER, res.fbo);
      generate(g, res, rotation, size, false);
      g.bindFramebuffer(g.FRAMEBUFFER, null);
      res.generated = state.freeze ? "frozen" : "live";
    }
    g.viewport(0, 0, cam.W, cam.H);
    g.clearColor(0, 0, 0, 1);
    g.clearDepth(1);
    g.clear(g.COLOR_BUFFER_BIT | g.DEPTH_BUFFER_BIT);
    if (state.background && scene.env) {
      const p = res.bg;
      g.useProgram(p.prog);
      setEnvUniforms(g, p, res);
      setDisplayUniforms(g, p);
      g.uniformMatrix3fv(p.u.u_eyeToWorld, false, cam.eyeToWorld);
      const ty = Math.tan(((state.fovy * Math.PI) / 180) / 2);
      g.uniform2f(p.u.u_tanHalf, (ty * cam.W) / cam.H, ty);
      g.uniform1f(p.u.u_pixelOmega, (2 * ty / cam.H) ** 2);
      g.disable(g.DEPTH_TEST);
      g.bindVertexArray(res.vao);
      g.drawArrays(g.TRIANGLES, 0, 3);
    }
    const p = res.mesh;
    g.useProgram(p.prog);
    setDisplayUniforms(g, p);
    g.uniformMatrix4fv(p.u.u_mv, false, cam.mv);
    g.uniformMatrix4fv(p.u.u_proj, false, cam.proj);
    g.uniformMatrix3fv(p.u.u_normalMatrix, false, cam.normalMatrix);
    g.uniform1i(p.u.u_normalize, state.normalize ? 1 : 0);
    g.uniform1i(p.u.u_mode, scene.modes.indexOf(state.mode));
    g.uniform1i(p.u.u_variant, Math.max(0, scene.variants.indexOf(state.variant)));
    g.uniform3fv(p.u.u_heat, new Float32Array(scene.heat_stops.flat()));
    g.uniform1f(p.u.u_heatMax, scene.heat_max_deg);
    g.uniform1i(p.u.u_hasMatcap, scene.matcap ? 1 : 0);
    g.activeTexture(g.TEXTURE0);
    g.bindTexture(g.TEXTURE_2D, res.sphere);
    g.uniform1i(p.u.u_sphere, 0);
    g.activeTexture(g.TEXTURE1);
    g.bindTexture(g.TEXTURE_2D, res.matcap);
    g.uniform1i(p.u.u_matcap, 1);
    g.enable(g.DEPTH_TEST);
    g.depthFunc(g.LESS);
    g.bindVertexArray(res.meshVao);
    g.drawElements(g.TRIANGLES, res.count, g.UNSIGNED_INT, 0);
    g.bindVertexArray(null);
    // The preview: the same sphere map, displayed.
    if (preview) {
      const pc = $("sphere");
      generate(pgl, preview, rotation, pc.width, true);
    }
    return cam;
  }

  function frame() {
    if (!dirty || !scene || !view) return;
    dirty = false;
    try {
      draw();
      gl.finish();
    } catch (e) {
      fail(String(e.message || e));
      return;
    }
    if (firstFrameMs === null) {
      firstFrameMs = performance.now();
      api.timing.firstFrameMs = firstFrameMs;
    }
    if (readyResolve) {
      const r = readyResolve;
      readyResolve = null;
      r(api.state());
    }
  }

  function invalidate() {
    if (!readyResolve) newReady();
    dirty = true;
    requestAnimationFrame(frame);
  }

  // Milliseconds per frame over `frames` frames, each waited for (readPixels). With `regenerate`
  // the sphere map is re-targeted for every frame even when frozen; without it the state decides
  // (regenerated each frame when live, kept when frozen).
  function benchmark(frames, regenerate) {
    const px = new Uint8Array(4);
    draw();
    gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, px);
    const t0 = performance.now();
    for (let i = 0; i < frames; i++) {
      if (regenerate) view.generated = null;
      draw();
      gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, px);
    }
    return (performance.now() - t0) / frames;
  }

  // The sphere map in use: {size, rgba: base64 of float32 RGBA}, rows bottom-up (GL-native: row 0
  // is t = 0).
  function sphereMap() {
    const g = gl, size = view.sphereSize;
    const px = new Float32Array(size * size * 4);
    g.bindFramebuffer(g.FRAMEBUFFER, view.fbo);
    g.readPixels(0, 0, size, size, g.RGBA, g.FLOAT, px);
    g.bindFramebuffer(g.FRAMEBUFFER, null);
    const bytes = new Uint8Array(px.buffer);
    let s = "";
    for (let i = 0; i < bytes.length; i += 0x8000) s += String.fromCharCode.apply(null, bytes.subarray(i, i + 0x8000));
    return { size, rgba: btoa(s) };
  }

  // ---------------------------------------------------------------- controls
  function applyChanges(c) {
    for (const [k, v] of Object.entries(c)) {
      if (!(k in state)) throw new Error(`unknown parameter ${k}`);
      if (k === "freeze" && !v) frozenRotation = null;
      if (k === "freeze" && v && !state.freeze) { frozenRotation = null; view && (view.generated = null); }
      state[k] = v;
    }
    if ("size" in c) sizeCanvas();
    syncControls();
    invalidate();
  }

  function syncControls() {
    $("mode").value = state.mode;
    $("variant").value = state.variant;
    $("tonemap").value = state.tonemap;
    $("exposure").value = state.exposure;
    $("expval").textContent = Number(state.exposure).toFixed(1);
    $("freeze").checked = state.freeze;
    $("background").checked = state.background;
    $("normalize").checked = state.normalize;
    $("bar").style.display = state.mode === "error" ? "block" : "none";
  }

  function fill(select, names) {
    select.innerHTML = "";
    for (const n of names) {
      const o = document.createElement("option");
      o.value = o.textContent = n;
      select.appendChild(o);
    }
  }

  function sizeCanvas() {
    const c = $("view");
    if (state.size) {
      [c.width, c.height] = state.size;
      c.style.width = state.size[0] + "px";
      c.style.height = state.size[1] + "px";
    } else {
      const r = $("stage").getBoundingClientRect();
      const dpr = window.devicePixelRatio || 1;
      c.width = Math.max(1, Math.round(r.width * dpr));
      c.height = Math.max(1, Math.round(r.height * dpr));
      c.style.width = r.width + "px";
      c.style.height = r.height + "px";
    }
  }

  function drawBar() {
    const c = $("barcanvas"), x = c.getContext("2d");
    const grad = x.createLinearGradient(0, 0, c.width, 0);
    scene.heat_stops.forEach((s, i) => grad.addColorStop(i / 5, `rgb(${s.map((v) => Math.round(v * 255)).join(",")})`));
    x.fillStyle = grad;
    x.fillRect(0, 0, c.width, c.height);
    $("barmax").textContent = `${scene.heat_max_deg}°`;
  }

  function wireControls() {
    fill($("mode"), scene.modes);
    fill($("variant"), scene.variants);
    fill($("tonemap"), scene.tonemaps);
    $("mode").onchange = (e) => applyChanges({ mode: e.target.value });
    $("variant").onchange = (e) => applyChanges({ variant: e.target.value });
    $("tonemap").onchange = (e) => applyChanges({ tonemap: e.target.value });
    $("exposure").oninput = (e) => applyChanges({ exposure: Number(e.target.value) });
    $("freeze").onchange = (e) => applyChanges({ freeze: e.target.checked });
    $("background").onchange = (e) => applyChanges({ background: e.target.checked });
    $("normalize").onchange = (e) => applyChanges({ normalize: e.target.checked });
    $("reset").onclick = () => applyChanges({ eye: initial.eye, target: initial.target, up: initial.up });
    $("screenshot").onclick = () => {
      $("view").toBlob((b) => {
        const a = document.createElement("a");
        a.href = URL.createObjectURL(b);
        a.download = "spheremap-view.png";
        a.click();
        setTimeout(() => URL.revokeObjectURL(a.href), 1000);
      });
    };
    drawBar();

    // Orbit (left drag), pan (right drag or shift), zoom (wheel). A horizontal drag of dx
    // pixels turns the eye by −dx/4 degrees about `up` (as `render --turntable` does), a
    // vertical one by −dy/4 degrees about the camera's right axis.
    const c = $("view");
    let drag = null;
    c.addEventListener("contextmenu", (e) => e.preventDefault());
    c.addEventListener("pointerdown", (e) => {
      drag = { x: e.clientX, y: e.clientY, pan: e.button === 2 || e.shiftKey };
      c.setPointerCapture(e.pointerId);
    });
    c.addEventListener("pointerup", () => { drag = null; });
    c.addEventListener("pointermove", (e) => {
      if (!drag) return;
      const dx = e.clientX - drag.x, dy = e.clientY - drag.y;
      drag.x = e.clientX;
      drag.y = e.clientY;
      if (dx === 0 && dy === 0) return;
      const k = unit(state.up);
      const v = sub(state.eye, state.target);
      if (drag.pan) {
        const f = unit(scale(v, -1)), s = unit(cross(f, k)), u = cross(s, f);
        const per = (2 * len(v) * Math.tan(((state.fovy * Math.PI) / 180) / 2)) / c.clientHeight;
        const t = add(scale(s, -dx * per), scale(u, dy * per));
        applyChanges({ eye: add(state.eye, t), target: add(state.target, t) });
        return;
      }
      let w = rotate(v, k, -dx / 4);
      const right = unit(cross(k, w));
      const w2 = rotate(w, right, -dy / 4);
      // Stop short of the poles (the camera would flip over `up`).
      if (Math.abs(dot(unit(w2), k)) < 0.995) w = w2;
      applyChanges({ eye: add(state.target, w) });
    });
    c.addEventListener("wheel", (e) => {
      e.preventDefault();
      const v = sub(state.eye, state.target);
      applyChanges({ eye: add(state.target, scale(v, Math.exp(e.deltaY * 0.001))) });
    }, { passive: false });

    // Dropped files go to the server, which reads them as the CLI does.
    const stage = $("stage"), dropBox = $("drop");
    stage.addEventListener("dragover", (e) => { e.preventDefault(); dropBox.style.display = "block"; });
    stage.addEventListener("dragleave", () => { dropBox.style.display = "none"; });
    stage.addEventListener("drop", (e) => {
      e.preventDefault();
      dropBox.style.display = "none";
      const files = Array.from(e.dataTransfer.files);
      if (files.length) loadFiles(files);
    });
    window.addEventListener("resize", () => { if (!state.size) { sizeCanvas(); invalidate(); } });
  }

  async function loadFiles(files) {
    errorBox.textContent = "";
    api.lastUpload = new Promise(async (resolve) => {
      for (const f of files) {
        const ext = (f.name.split(".").pop() || "").toLowerCase();
        const kind = scene.mesh_extensions.includes(ext) ? "mesh"
          : state.mode === "matcap" ? "matcap" : "env";
        if (!scene.uploads) {
          showError(`${f.name}: dropping files needs the spheremap server (this page is a static export)`);
          continue;
        }
        statusBox.textContent = `reading ${f.name}…`;
        try {
          const r = await fetch(`upload/${kind}?name=${encodeURIComponent(f.name)}`, {
            method: "POST", body: f, headers: { "X-Spheremap-Upload": "1" },
          });
          const j = await r.json().catch(() => ({ error: `${f.name}: HTTP ${r.status}` }));
          if (!r.ok || j.error) { showError(j.error || `${f.name}: HTTP ${r.status}`); continue; }
          await reload();
          statusBox.textContent = `${f.name} loaded`;
        } catch (err) {
          showError(`${f.name}: ${err.message || err}`);
        }
      }
      statusBox.textContent = statusText();
      resolve(errorBox.textContent);
    });
    return api.lastUpload;
  }
  api.drop = loadFiles;

  function statusText() {
    const m = scene.mesh, e = scene.env, c = scene.matcap;
    const parts = [`${m.name}: ${m.vertices} vertices, ${m.triangles} triangles`];
    if (e) parts.push(`${e.name}: ${e.mapping} ${e.source_width}×${e.source_height}` + (e.clamped ? ` (${e.clamped} values over 65504 clamped)` : ""));
    if (c) parts.push(`MatCap ${c.name}`);
    return parts.join(" · ");
  }

  // ---------------------------------------------------------------- start
  let initial = null;

  async function reload(preloaded) {
    const d = preloaded || await loadData();
    const firstLoad = scene === null;
    const meshChanged = !firstLoad && d.s.mesh.name !== scene.mesh.name;
    scene = d.s;
    api.version = scene.version;
    view = buildView(d);
    view.generated = null;
    if (state.freeze) frozenRotation = null;
    const pc = $("sphere");
    pgl = pgl || pc.getContext("webgl2", { antialias: false, preserveDrawingBuffer: true });
    preview = pgl ? makeGen(pgl, d) : null;
    if (meshChanged) {
      state.eye = null;
      state.target = null;
    }
    statusBox.textContent = statusText();
    invalidate();
  }

  async function start() {
    try {
      const c = $("view");
      gl = c.getContext("webgl2", { antialias: false, preserveDrawingBuffer: true, alpha: false });
      if (!gl) throw new Error("this browser has no WebGL2");
      if (!gl.getExtension("EXT_color_buffer_float")) throw new Error("this browser cannot render to float textures (EXT_color_buffer_float)");
      gl.getExtension("OES_texture_float_linear");
      // The rasterizer's vertex snapping: `spheremap render --subpixel-bits` draws the same.
      api.subpixelBits = gl.getParameter(gl.SUBPIXEL_BITS);
      const mode = params.get("mode");
      if (mode !== null) state.mode = mode;
      const variant = params.get("variant");
      if (variant !== null) state.variant = variant;
      const tonemap = params.get("tonemap");
      if (tonemap !== null) state.tonemap = tonemap;
      state.exposure = numParam("exposure", 0);
      state.fovy = numParam("fovy", 40);
      if (!(state.fovy > 0 && state.fovy < 180)) throw new Error(`URL parameter fovy=${state.fovy}: must be in (0, 180)`);
      state.eye = vec3Param("eye");
      state.target = vec3Param("target");
      state.up = vec3Param("up") || [0, 1, 0];
      state.freeze = boolParam("freeze", false);
      state.background = params.get("background") === null ? true : params.get("background") === "env";
      state.normalize = boolParam("normalize", true);
      state.smsize = numParam("smsize", 512);
      state.supersample = numParam("supersample", 2);
      if (!(Number.isInteger(state.supersample) && state.supersample >= 1 && state.supersample <= 8)) throw new Error(`URL parameter supersample=${state.supersample}: an integer from 1 to 8`);
      if (!(Number.isInteger(state.smsize) && state.smsize >= 8 && state.smsize <= 8192)) throw new Error(`URL parameter smsize=${state.smsize}: an integer from 8 to 8192`);
      const size = params.get("size");
      if (size !== null) {
        const s = size.split(",").map(Number);
        if (s.length !== 2 || !s.every((v) => Number.isInteger(v) && v >= 1 && v <= 8192)) throw new Error(`URL parameter size=${size}: expected W,H`);
        state.size = s;
      }
      sizeCanvas();
      const d0 = await loadData();
      for (const [name, value, list] of [["mode", state.mode, d0.s.modes], ["variant", state.variant, d0.s.variants], ["tonemap", state.tonemap, d0.s.tonemaps]]) {
        if (!list.includes(value)) throw new Error(`URL parameter ${name}=${value}: expected one of ${list.join(", ")}`);
      }
      scene = null;
      await reload(d0);
      wireControls();
      syncControls();
      camera();
      initial = { eye: state.eye.slice(), target: state.target.slice(), up: state.up.slice() };
      invalidate();
    } catch (e) {
      fail(String(e.message || e));
    }
  }

  start();
})();
