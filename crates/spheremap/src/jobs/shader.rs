//! Shader snippets for per-vertex GL_SPHERE_MAP texgen, per-pixel sphere-map lookup and MatCap,
//! in GLSL, WGSL and HLSL — the same maths as the core, in our conventions (eye space: viewer
//! at the origin looking down −Z, +Y up; (s, t) with t up, so sample a texture uploaded bottom
//! row first at (s, t), or one uploaded top row first — as images load — at (s, 1 − t)).
//!
//! * `texgen`: OpenGL's own formula, `m = 2 √(rx² + ry² + (rz + 1)²)`, `st = r.xy/m + ½` with
//!   `r = reflect(normalize(eye_pos), eye_normal)`; exactly what fixed-function GL computes (for
//!   the straight-ahead reflection `r = (0, 0, −1)` it divides by 0, as GL does).
//! * `lookup`: per pixel. The same map, but `1 + rz` is computed without cancellation near the
//!   rim (`(rx² + ry²)/(1 − rz)` when `rz < 0`), as the core does; then the texture is sampled.
//! * `matcap`: the classic (`n.xy/2 + ½`), three.js and perspective-corrected variants of
//!   [`crate::mappings::matcap`].
//!
//! The tests compile every snippet (naga for GLSL and WGSL, glslang for HLSL) and execute the
//! GLSL in Mesa against the core on a grid of directions.

use crate::base::error::Result;

pub const LANGS: [&str; 3] = ["glsl", "wgsl", "hlsl"];
pub const WHATS: [&str; 3] = Snippet::NAMES;

const GLSL_TEXGEN: &str = r#"// GL_SPHERE_MAP texgen (spheremap): OpenGL's per-vertex formula.
// eye_pos: the vertex in eye space (modelview * position); eye_normal: the unit eye-space
// normal (normal matrix * normal, normalized as GL_NORMALIZE does). Returns (s, t), t up.
vec2 sphere_map_texgen(vec3 eye_pos, vec3 eye_normal) {
    vec3 u = normalize(eye_pos);
    vec3 r = u - 2.0 * dot(eye_normal, u) * eye_normal;
    float m = 2.0 * sqrt(r.x * r.x + r.y * r.y + (r.z + 1.0) * (r.z + 1.0));
    return r.xy / m + 0.5;
}
"#;

const GLSL_LOOKUP: &str = r#"// Per-pixel sphere-map lookup (spheremap). r: the reflection vector in eye space (any
// length but 0). Returns (s, t), t up; 1 + r.z is computed without cancellation at the rim.
vec2 sphere_map_st(vec3 r) {
    r = normalize(r);
    float q = r.x * r.x + r.y * r.y;
    float zp1 = r.z >= 0.0 ? 1.0 + r.z : q / (1.0 - r.z);
    return r.xy / (2.0 * sqrt(q + zp1 * zp1)) + 0.5;
}

// The environment seen by a mirror at eye_pos with normal eye_normal (both eye space), from a
// sphere map uploaded top row first (as images load): hence t is flipped.
vec4 sphere_map_lookup(sampler2D sphere_map, vec3 eye_pos, vec3 eye_normal) {
    vec3 r = reflect(normalize(eye_pos), normalize(eye_normal));
    vec2 st = sphere_map_st(r);
    return texture(sphere_map, vec2(st.x, 1.0 - st.y));
}
"#;

const GLSL_MATCAP: &str = r#"// MatCap coordinates (spheremap). n: eye-space normal; p: eye-space position of the shaded
// point. Returns (u, v), v up; sample an image uploaded top row first at (u, 1 - v).
vec2 matcap_classic(vec3 n) {
    return normalize(n).xy * 0.5 + 0.5;
}

// three.js MeshMatcapMaterial.
vec2 matcap_threejs(vec3 n, vec3 p) {
    n = normalize(n);
    vec3 v = normalize(-p);
    vec3 x = normalize(vec3(v.z, 0.0, -v.x));
    vec3 y = cross(v, x);
    return vec2(dot(x, n), dot(y, n)) * 0.495 + 0.5;
}

// Perspective-corrected: n rotated by the minimal rotation taking the view ray to -Z.
vec2 matcap_perspective(vec3 n, vec3 p) {
    n = normalize(n);
    vec3 d = normalize(p);
    float c = -d.z;
    vec3 k = vec3(-d.y, d.x, 0.0);
    vec3 rn = c * n + cross(k, n) + k * (dot(k, n) / (1.0 + c));
    return rn.xy * 0.5 + 0.5;
}
"#;

const WGSL_TEXGEN: &str = r#"// GL_SPHERE_MAP texgen (spheremap): OpenGL's per-vertex formula.
// eye_pos: the vertex in eye space; eye_normal: the unit eye-space normal. Returns (s, t), t up.
fn sphere_map_texgen(eye_pos: vec3<f32>, eye_normal: vec3<f32>) -> vec2<f32> {
    let u = normalize(eye_pos);
    let r = u - 2.0 * dot(eye_normal, u) * eye_normal;
    let m = 2.0 * sqrt(r.x * r.x + r.y * r.y + (r.z + 1.0) * (r.z + 1.0));
    return r.xy / m + vec2<f32>(0.5, 0.5);
}
"#;

const WGSL_LOOKUP: &str = r#"// Per-pixel sphere-map lookup (spheremap). r: the reflection vector in eye space.
// Returns (s, t), t up; 1 + r.z is computed without cancellation at the rim.
fn sphere_map_st(r_in: vec3<f32>) -> vec2<f32> {
    let r = normalize(r_in);
    let q = r.x * r.x + r.y * r.y;
    let zp1 = select(q / (1.0 - r.z), 1.0 + r.z, r.z >= 0.0);
    return r.xy / (2.0 * sqrt(q + zp1 * zp1)) + vec2<f32>(0.5, 0.5);
}

// The environment seen by a mirror at eye_pos with normal eye_normal, from a sphere map whose
// first row is the top of the image (as images load; WebGPU's v is down).
fn sphere_map_lookup(t: texture_2d<f32>, s: sampler, eye_pos: vec3<f32>, eye_normal: vec3<f32>) -> vec4<f32> {
    let r = reflect(normalize(eye_pos), normalize(eye_normal));
    let st = sphere_map_st(r);
    return textureSample(t, s, vec2<f32>(st.x, 1.0 - st.y));
}
"#;

const WGSL_MATCAP: &str = r#"// MatCap coordinates (spheremap). n: eye-space normal; p: eye-space position. Returns
// (u, v), v up; sample at (u, 1 - v) (WebGPU's v is down).
fn matcap_classic(n: vec3<f32>) -> vec2<f32> {
    return normalize(n).xy * 0.5 + vec2<f32>(0.5, 0.5);
}

// three.js MeshMatcapMaterial.
fn matcap_threejs(n_in: vec3<f32>, p: vec3<f32>) -> vec2<f32> {
    let n = normalize(n_in);
    let v = normalize(-p);
    let x = normalize(vec3<f32>(v.z, 0.0, -v.x));
    let y = cross(v, x);
    return vec2<f32>(dot(x, n), dot(y, n)) * 0.495 + vec2<f32>(0.5, 0.5);
}

// Perspective-corrected: n rotated by the minimal rotation taking the view ray to -Z.
fn matcap_perspective(n_in: vec3<f32>, p: vec3<f32>) -> vec2<f32> {
    let n = normalize(n_in);
    let d = normalize(p);
    let c = -d.z;
    let k = vec3<f32>(-d.y, d.x, 0.0);
    let rn = c * n + cross(k, n) + k * (dot(k, n) / (1.0 + c));
    return rn.xy * 0.5 + vec2<f32>(0.5, 0.5);
}
"#;

const HLSL_TEXGEN: &str = r#"// GL_SPHERE_MAP texgen (spheremap): OpenGL's per-vertex formula, in our right-handed eye
// space (viewer looking down -Z). eye_pos: the vertex in eye space; eye_normal: the unit
// eye-space normal. Returns (s, t), t up.
float2 sphere_map_texgen(float3 eye_pos, float3 eye_normal) {
    float3 u = normalize(eye_pos);
    float3 r = u - 2.0 * dot(eye_normal, u) * eye_normal;
    float m = 2.0 * sqrt(r.x * r.x + r.y * r.y + (r.z + 1.0) * (r.z + 1.0));
    return r.xy / m + 0.5;
}
"#;

const HLSL_LOOKUP: &str = r#"// Per-pixel sphere-map lookup (spheremap), in our right-handed eye space (viewer looking
// down -Z). r: the reflection vector. Returns (s, t), t up.
float2 sphere_map_st(float3 r) {
    r = normalize(r);
    float q = r.x * r.x + r.y * r.y;
    float zp1 = r.z >= 0.0 ? 1.0 + r.z : q / (1.0 - r.z);
    return r.xy / (2.0 * sqrt(q + zp1 * zp1)) + 0.5;
}

// The environment seen by a mirror at eye_pos with normal eye_normal, from a sphere map whose
// first row is the top of the image (D3D's v is down).
float4 sphere_map_lookup(Texture2D t, SamplerState s, float3 eye_pos, float3 eye_normal) {
    float3 r = reflect(normalize(eye_pos), normalize(eye_normal));
    float2 st = sphere_map_st(r);
    return t.Sample(s, float2(st.x, 1.0 - st.y));
}
"#;

const HLSL_MATCAP: &str = r#"// MatCap coordinates (spheremap), in our right-handed eye space. n: eye-space normal; p:
// eye-space position. Returns (u, v), v up; sample at (u, 1 - v) (D3D's v is down).
float2 matcap_classic(float3 n) {
    return normalize(n).xy * 0.5 + 0.5;
}

// three.js MeshMatcapMaterial.
float2 matcap_threejs(float3 n, float3 p) {
    n = normalize(n);
    float3 v = normalize(-p);
    float3 x = normalize(float3(v.z, 0.0, -v.x));
    float3 y = cross(v, x);
    return float2(dot(x, n), dot(y, n)) * 0.495 + 0.5;
}

// Perspective-corrected: n rotated by the minimal rotation taking the view ray to -Z.
float2 matcap_perspective(float3 n, float3 p) {
    n = normalize(n);
    float3 d = normalize(p);
    float c = -d.z;
    float3 k = float3(-d.y, d.x, 0.0);
    float3 rn = c * n + cross(k, n) + k * (dot(k, n) / (1.0 + c));
    return rn.xy * 0.5 + 0.5;
}
"#;

crate::base::named::named_enum! {
    /// A shading language of the snippets.
    #[derive(Default)]
    pub enum Language: "language" as "lang" {
        #[default]
        Glsl = "glsl",
        Wgsl = "wgsl",
        Hlsl = "hlsl",
    }
}

crate::base::named::named_enum! {
    /// What a snippet computes: per-vertex GL_SPHERE_MAP texgen, the per-pixel sphere-map
    /// lookup, the MatCap lookup.
    pub enum Snippet: "snippet" as "what" {
        Texgen = "texgen",
        Lookup = "lookup",
        Matcap = "matcap",
    }
}

/// The snippet for `lang` (glsl, wgsl, hlsl) and `what` (texgen, lookup, matcap).
pub fn snippet(lang: &str, what: &str) -> Result<&'static str> {
    Ok(source(Language::parse(lang)?, Snippet::parse(what)?))
}

/// The snippet `what` in `lang`.
pub fn source(lang: Language, what: Snippet) -> &'static str {
    let table = match lang {
        Language::Glsl => [GLSL_TEXGEN, GLSL_LOOKUP, GLSL_MATCAP],
        Language::Wgsl => [WGSL_TEXGEN, WGSL_LOOKUP, WGSL_MATCAP],
        Language::Hlsl => [HLSL_TEXGEN, HLSL_LOOKUP, HLSL_MATCAP],
    };
    table[what as usize]
}
