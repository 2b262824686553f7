"""Shader snippets: compiled by glslang (GLSL and HLSL; naga compiles GLSL and WGSL in
crates/spheremap/tests/shader.rs) and the GLSL executed in Mesa against the core."""

import os
import shutil
import subprocess

import numpy as np
import pytest

import spheremap as sm
from conftest import cli


def snippet(lang, what):
    r = cli("shader", "--lang", lang, "--what", what)
    assert r.returncode == 0, r.stderr
    return r.stdout


@pytest.fixture(scope="module")
def glslang():
    exe = shutil.which("glslangValidator")
    if exe is None:
        if os.environ.get("SPHEREMAP_REQUIRE_MESA") == "1":
            pytest.fail("glslangValidator (Debian: glslang-tools) is required in CI")
        pytest.skip("glslangValidator not installed")
    return exe


GLSL_MAIN = {
    "texgen": "o = vec4(sphere_map_texgen(p, n), 0.0, 1.0);",
    "lookup": "o = sphere_map_lookup(env, p, n) + vec4(sphere_map_st(n), 0.0, 0.0);",
    "matcap": "o = vec4(matcap_classic(n) + matcap_threejs(n, p) + matcap_perspective(n, p), 0.0, 1.0);",
}
HLSL_MAIN = {
    "texgen": "return float4(sphere_map_texgen(p, n), 0.0, 1.0);",
    "lookup": "return sphere_map_lookup(env, samp, p, n) + float4(sphere_map_st(n), 0.0, 0.0);",
    "matcap": "return float4(matcap_classic(n) + matcap_threejs(n, p) + matcap_perspective(n, p), 0.0, 1.0);",
}


@pytest.mark.parametrize("what", ["texgen", "lookup", "matcap"])
def test_glsl_and_hlsl_compile_with_glslang(glslang, tmp_path, what):
    for version in ("330", "300 es"):
        prec = "precision highp float;\n" if "es" in version else ""
        src = (f"#version {version}\n{prec}in vec3 p;\nin vec3 n;\nout vec4 o;\nuniform sampler2D env;\n"
               f"{snippet('glsl', what)}\nvoid main() {{ {GLSL_MAIN[what]} }}\n")
        f = tmp_path / f"{what}.frag"
        f.write_text(src)
        r = subprocess.run([glslang, str(f)], capture_output=True, text=True)
        assert r.returncode == 0, (version, r.stdout, r.stderr)
    src = (f"Texture2D env;\nSamplerState samp;\n{snippet('hlsl', what)}\n"
           f"float4 main(float3 p : TEXCOORD0, float3 n : TEXCOORD1) : SV_Target {{ {HLSL_MAIN[what]} }}\n")
    f = tmp_path / f"{what}.hlsl"
    f.write_text(src)
    r = subprocess.run([glslang, "-V", "-D", "-e", "main", "-S", "frag", str(f), "-o", str(tmp_path / "out.spv")],
                       capture_output=True, text=True)
    assert r.returncode == 0, (r.stdout, r.stderr)


def inputs(n=64, seed=1):
    """Eye-space positions in front of the viewer and unit normals facing it, on an n x n grid."""
    rng = np.random.default_rng(seed)
    p = np.stack([rng.uniform(-2, 2, (n, n)), rng.uniform(-2, 2, (n, n)), rng.uniform(-8, -1, (n, n))], -1)
    nrm = rng.normal(size=(n, n, 3))
    nrm /= np.linalg.norm(nrm, axis=-1, keepdims=True)
    facing = np.sum(nrm * -p, -1) < 0
    nrm[facing] *= -1  # toward the viewer
    return p.astype(np.float32), nrm.astype(np.float32)


FETCH = "vec3 p = texelFetch(in0, ivec2(gl_FragCoord.xy), 0).xyz;\nvec3 n = texelFetch(in1, ivec2(gl_FragCoord.xy), 0).xyz;\n"


def run(mesa, body, what, extra=""):
    p, n = inputs()
    src = (f"#version 130\nuniform sampler2D in0;\nuniform sampler2D in1;\n{extra}{snippet('glsl', what)}\n"
           f"void main() {{\n{FETCH}{body}\n}}\n")
    return p, n, src


def test_glsl_texgen_and_lookup_run_in_mesa_like_the_core(mesa):
    p, n, src = run(mesa, "gl_FragColor = vec4(sphere_map_texgen(p, n), 0.0, 1.0);", "texgen")
    out = mesa.mesa_run_fragment(src, [p, n], (64, 64))
    want = sm.sphere_texgen(p.reshape(-1, 3), n.reshape(-1, 3), np.eye(4)).reshape(64, 64, 2)
    err = np.abs(out[..., :2] - want).max()
    print(f"texgen: max |GLSL in Mesa - core| = {err:.2e}")
    assert err < 2e-6
    # Per-pixel lookup coordinates of the reflection vector.
    body = "vec3 r = reflect(normalize(p), n);\ngl_FragColor = vec4(sphere_map_st(r), 0.0, 1.0);"
    p, n, src = run(mesa, body, "lookup", "uniform sampler2D env;\n")
    out = mesa.mesa_run_fragment(src, [p, n], (64, 64))
    u = p / np.linalg.norm(p, axis=-1, keepdims=True)
    r = sm.reflect(u.astype(np.float64), n.astype(np.float64))
    want = sm.dir_to_sphere(r)
    err = np.abs(out[..., :2] - want).max()
    print(f"lookup st: max |GLSL in Mesa - core| = {err:.2e}")
    assert err < 2e-6


def test_glsl_lookup_samples_the_right_texel(mesa):
    # A 32 x 32 texture whose texels hold their own (s, t) (row 0 = the top = t near 1),
    # uploaded top row first as the snippet expects: the lookup returns the (s, t) it computed.
    m = 32
    c = (np.arange(m) + 0.5) / m
    s, t = np.meshgrid(c, c[::-1])
    tex = np.stack([s, t, np.zeros_like(s), np.ones_like(s)], -1).astype(np.float32)
    body = ("vec3 r = reflect(normalize(p), n);\n"
            "gl_FragColor = vec4(sphere_map_lookup(env, p, n).xy, sphere_map_st(r));")
    p, n, src = run(mesa, body, "lookup", "uniform sampler2D env;\n")
    out = mesa.mesa_run_fragment(src, [p, n, ("env", tex, True)], (64, 64))
    got, st = out[..., :2], out[..., 2:]
    inner = np.all((st > 0.5 / m) & (st < 1 - 0.5 / m), -1)  # away from the clamped border
    assert inner.mean() > 0.9
    err = np.abs(got - st)[inner].max()
    print(f"lookup sampling: max |sampled - st| = {err:.2e} over {inner.sum()} pixels")
    assert err < 1e-3  # bilinear of a linear field, filtering weights at 8-bit precision in llvmpipe


def test_glsl_matcap_runs_in_mesa_like_the_core(mesa):
    for fn, variant in (("matcap_classic(n)", "classic"), ("matcap_threejs(n, p)", "threejs"),
                        ("matcap_perspective(n, p)", "perspective")):
        p, n, src = run(mesa, f"gl_FragColor = vec4({fn}, 0.0, 1.0);", "matcap")
        out = mesa.mesa_run_fragment(src, [p, n], (64, 64))
        want = sm.matcap_uv(n.astype(np.float64), p.astype(np.float64), variant=variant)
        err = np.abs(out[..., :2] - want).max()
        print(f"matcap {variant}: max |GLSL in Mesa - core| = {err:.2e}")
        assert err < 2e-6, variant


def test_shader_cli_errors():
    r = cli("shader", "--lang", "metal", "--what", "lookup")
    assert r.returncode == 2 and "lang" in r.stderr and r.stderr.count("\n") == 1
