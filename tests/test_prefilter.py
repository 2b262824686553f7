"""Prefiltered lighting and the texture containers: `spheremap prefilter`, Python's `prefilter`,
`read_texture` / `write_texture`, and KTX2 / DDS read by `info` and `convert`.

The references are independent of the core: the GGX split-sum kernel and its normalization in
numpy from the textbook formulas; the files' bytes parsed here from the KTX 2.0 and DDS
specifications; a cube KTX2 read by `ktx-parse`, the KTX 2.0 parser of three.js's
`KTX2Loader` and glTF-Transform, and cube and 2D DDS files read by Babylon.js's `DDSTools` (both
from npm, run by Node.js), the faces checked against the cube-map face table of the OpenGL and
Vulkan specifications. (The Rust tests open the same files with the `ktx2` and `ddsfile` crates;
OpenImageIO 3.2's and Pillow's DDS readers read no float formats, "Unsupported DXGI format" for
RGBA16F and RGBA32F, so they cannot be among them.)

The Node.js tests install their package with npm into target/peers on first use; they are
skipped when Node.js or npm is missing, unless SPHEREMAP_REQUIRE_NODE=1 (CI sets it).
"""

import json
import math
import os
import shutil
import struct
import subprocess

import numpy as np
import pytest

import spheremap
from conftest import cli

HERE = os.path.dirname(__file__)
SKY = os.path.join(HERE, "..", "testdata", "hdri", "sky.exr")
PEERS = os.path.join(HERE, "..", "target", "peers")
KTX_PARSE = "ktx-parse@2.0.0"
BABYLON = "@babylonjs/core@9.37.1"


def ggx_d(alpha, c):
    a2 = alpha * alpha
    return a2 / (math.pi * (c * c * (a2 - 1) + 1) ** 2)


def latlong_dirs(h, w):
    """Directions of a (h, w) lat-long's texel centres in spheremap's default preset."""
    uv = np.stack(np.meshgrid((np.arange(w) + 0.5) / w, (np.arange(h) + 0.5) / h), -1)
    return spheremap.uv_to_dir(uv.reshape(-1, 2), "latlong")[0].reshape(h, w, 3)


def test_furnace_every_mapping_and_the_sphere_is_the_matcap():
    env = np.full((32, 64, 3), 1.5, np.float32)
    for to in ["cube", "octahedral", "latlong"]:
        for irr in [False, True]:
            levels = spheremap.prefilter(
                env, to=to, size=16, levels=None if irr else 3, irradiance=irr, samples=1
            )
            for lv in levels:
                assert np.allclose(lv, 1.5, rtol=2e-4), (to, irr)
    # The sphere variant is the exact GGX MatCap of albedo 1 of each level's roughness.
    rng = np.random.default_rng(1)
    env = (rng.random((32, 64, 3)) * 2).astype(np.float32)
    # (Four samples per texel and the tolerance of convert and bake_matcap.)
    levels, reports = spheremap.prefilter(
        env, to="sphere", size=32, levels=3, look=(1, 0, -1), samples=4, tolerance=1e-5, report=True
    )
    for lv, rep in zip(levels, reports):
        if rep["roughness"] == 0:
            want = spheremap.convert(env, "latlong", "sphere", size=32, look=(1, 0, -1))
        else:
            want = spheremap.bake_matcap(
                env, roughness=rep["roughness"], albedo=(1, 1, 1), size=lv.shape[0], look=(1, 0, -1)
            )
        assert np.array_equal(lv, want), rep


def test_a_level_against_the_split_sum_integral_in_numpy():
    # A smooth map with a bright spot; levels 2 and 3 of a 4-level latlong chain against the
    # kernel summed over every texel (4x4 sub-points, nearest texel: the map is smooth).
    h, w = 32, 64
    d = latlong_dirs(h, w)
    spot = np.array([0.3, 0.5, -0.8]) / np.linalg.norm([0.3, 0.5, -0.8])
    env = (0.3 + 0.2 * d[..., 0:1] + 20 * np.exp((d @ spot - 1) / 0.02)[..., None] * [1, 0.8, 0.5]).astype(
        np.float32
    )
    levels, reports = spheremap.prefilter(env, to="latlong", size=16, levels=4, samples=1, report=True)
    k = 4
    dd = latlong_dirs(h * k, w * k).reshape(-1, 3)
    om = spheremap.texel_solid_angles("latlong", w * k, h * k).reshape(-1)
    lv = np.repeat(np.repeat(env, k, 0), k, 1).reshape(-1, 3).astype(np.float64)

    def ld(n, alpha):
        c = dd @ n
        m = c > 0
        nh = np.sqrt((1 + c[m]) / 2)
        wgt = ggx_d(alpha, nh) * c[m] / 4 * om[m]
        return (lv[m] * wgt[:, None]).sum(0) / wgt.sum()

    for i in (2, 3):
        r = reports[i]["roughness"]
        alpha = r * r
        out = levels[i]
        # Each texel is the solid-angle mean of its children's integrals (a texel wider than the
        # lobe, or than 0.1 rad, is split: these levels' texels span 36-72 degrees).
        ch = reports[i]["children"]
        assert ch > 1, ch
        fh, fw = out.shape[0] * ch, out.shape[1] * ch
        fine = latlong_dirs(fh, fw)
        fom = spheremap.texel_solid_angles("latlong", fw, fh).reshape(fh, fw)
        worst = 0.0
        for y in range(0, out.shape[0], 2):
            for x in range(0, out.shape[1], 3):
                acc, wsum = 0.0, 0.0
                for fy in range(y * ch, (y + 1) * ch):
                    for fx in range(x * ch, (x + 1) * ch):
                        acc = acc + ld(fine[fy, fx], alpha) * fom[fy, fx]
                        wsum += fom[fy, fx]
                want = acc / wsum
                worst = max(worst, float(np.max(np.abs(out[y, x] - want) / np.maximum(want, 0.3))))
        assert worst < 5e-3, (i, r, worst)


def test_cli_prefilter_writes_a_cube_texture_and_level_images(tmp_path):
    out = tmp_path / "sky.ktx2"
    p = cli("prefilter", SKY, "-o", out, "--size", "32", "--levels", "4", "--samples", "1", "--json")
    assert p.returncode == 0, p.stderr
    rep = json.loads(p.stdout)
    assert rep["mapping"] == "cube" and len(rep["levels"]) == 4 and rep["output"] == [str(out)]
    r = [lv["roughness"] for lv in rep["levels"]]
    # Filament's mapping: r (2 - r) = i / (L - 1).
    assert np.allclose([x * (2 - x) for x in r], [0, 1 / 3, 2 / 3, 1])
    levels, cube = spheremap.read_texture(out)
    assert cube and [lv.shape for lv in levels] == [
        (6, 32, 32, 4),
        (6, 16, 16, 4),
        (6, 8, 8, 4),
        (6, 4, 4, 4),
    ]
    info = spheremap.info(str(out))
    assert info["format"] == "KTX2" and info["recorded"]["mapping"] == "cube"
    # convert reads the texture's level 0 as the cube it is, with no --from.
    p = cli("convert", out, tmp_path / "back.exr", "--to", "latlong", "--size", "16")
    assert p.returncode == 0, p.stderr
    # The same chain as images, one per level, and as DDS.
    p = cli(
        "prefilter",
        SKY,
        "-o",
        tmp_path / "sky_{level}.exr",
        "--size",
        "32",
        "--levels",
        "4",
        "--samples",
        "1",
    )
    assert p.returncode == 0, p.stderr
    for i, lv in enumerate(levels):
        img = spheremap.read_image(str(tmp_path / f"sky_{i}.exr"))
        faces = spheremap.cube_from_layout(img, "hcross")
        assert np.allclose(faces, lv[..., :3], rtol=1e-6, atol=1e-7), i
    p = cli(
        "prefilter",
        SKY,
        "-o",
        tmp_path / "sky.dds",
        "--size",
        "32",
        "--levels",
        "4",
        "--samples",
        "1",
        "--half",
    )
    assert p.returncode == 0, p.stderr
    dl, dcube = spheremap.read_texture(tmp_path / "sky.dds")
    assert dcube and all(np.allclose(a, b, rtol=1e-3, atol=1e-4) for a, b in zip(dl, levels))


def test_cli_prefilter_irradiance_and_errors(tmp_path):
    p = cli(
        "prefilter",
        SKY,
        "-o",
        tmp_path / "irr.exr",
        "--irradiance",
        "--to",
        "latlong",
        "--size",
        "8",
        "--json",
    )
    assert p.returncode == 0, p.stderr
    rep = json.loads(p.stdout)
    assert rep["irradiance"] and rep["levels"][0]["roughness"] is None
    irr = spheremap.read_image(str(tmp_path / "irr.exr"))
    assert irr.shape == (8, 16, 3) and (irr > 0).all()
    for args, what in [
        (["-o", tmp_path / "x.exr", "--levels", "3"], "{level}"),
        (["-o", tmp_path / "x.ktx2", "--levels", "40"], "--levels"),
        (["-o", tmp_path / "x.ktx2", "--irradiance", "--levels", "2"], "--levels"),
        (["-o", tmp_path / "x.ktx2", "--roughness-map", "unreal"], "--roughness-map"),
        (["-o", tmp_path / "x.ktx2", "--layout", "hcross"], "--layout"),
        (["-o", tmp_path / "x.webp"], "x.webp"),
    ]:
        p = cli("prefilter", SKY, *args)
        assert p.returncode == 2 and what in p.stderr and len(p.stderr.strip().splitlines()) == 1, p.stderr
    assert not any(tmp_path.glob("x*"))


def test_python_prefilter_names_the_argument():
    env = np.ones((16, 32, 3), np.float32)
    for kwargs, name in [
        ({"levels": 0}, "levels"),
        ({"to": "globe"}, "to"),
        ({"roughness_map": "unreal"}, "roughness_map"),
        ({"irradiance": True, "levels": 2}, "levels"),
    ]:
        with pytest.raises(ValueError, match=name):
            spheremap.prefilter(env, **kwargs)


# -- the containers, byte by byte -----------------------------------------------------------------


def test_ktx2_bytes_follow_the_specification(tmp_path):
    rng = np.random.default_rng(2)
    levels = [rng.random((16, 32, 3)).astype(np.float32), rng.random((8, 16, 3)).astype(np.float32)]
    path = tmp_path / "t.ktx2"
    spheremap.write_texture(path, levels, mapping="latlong")
    b = path.read_bytes()
    assert b[:12] == b"\xabKTX 20\xbb\r\n\x1a\n"
    vk, ts, w, h, d, layers, faces, nlev, sc = struct.unpack_from("<9I", b, 12)
    assert (vk, ts, w, h, d, layers, faces, nlev, sc) == (109, 4, 32, 16, 0, 0, 1, 2, 0)
    dfd_off, dfd_len, kvd_off, kvd_len = struct.unpack_from("<4I", b, 48)
    # Key/value pairs: length, key NUL value NUL, padded to 4.
    kv, at = {}, kvd_off
    while at < kvd_off + kvd_len:
        (n,) = struct.unpack_from("<I", b, at)
        key, _, val = b[at + 4 : at + 4 + n].partition(b"\0")
        kv[key.decode()] = val.rstrip(b"\0").decode()
        at += 4 + n + (-(4 + n)) % 4
    assert kv["KTXorientation"] == "rd" and kv["spheremap"].startswith("mapping=latlong")
    for i, lv in enumerate(levels):
        off, length, ulen = struct.unpack_from("<3Q", b, 80 + 24 * i)
        assert off % 16 == 0 and length == ulen == lv.shape[0] * lv.shape[1] * 16
        px = np.frombuffer(b, np.float32, length // 4, off).reshape(lv.shape[0], lv.shape[1], 4)
        assert np.array_equal(px[..., :3], lv) and (px[..., 3] == 1).all()
    # Level 1 comes before level 0 in the file (smallest first).
    assert struct.unpack_from("<Q", b, 104)[0] < struct.unpack_from("<Q", b, 80)[0]
    back, cube = spheremap.read_texture(path)
    assert not cube and np.array_equal(back[1][..., :3], levels[1])


def test_dds_bytes_follow_the_specification(tmp_path):
    f = 4
    stack = np.arange(6 * f * f * 3, dtype=np.float32).reshape(6 * f, f, 3)
    path = tmp_path / "c.dds"
    spheremap.write_texture(path, [stack], cube=True, half=True)
    b = path.read_bytes()
    assert b[:4] == b"DDS " and struct.unpack_from("<I", b, 4)[0] == 124
    hh, ww = struct.unpack_from("<2I", b, 12)
    assert (hh, ww) == (f, f) and b[84:88] == b"DX10"
    caps2 = struct.unpack_from("<I", b, 112)[0]
    assert caps2 & 0x200 and caps2 & 0xFC00 == 0xFC00
    dxgi, dim, misc, arr = struct.unpack_from("<4I", b, 128)
    assert (dxgi, dim, misc & 4, arr) == (10, 3, 4, 1)
    px = np.frombuffer(b, np.float16, 6 * f * f * 4, 148).reshape(6 * f, f, 4)
    # Faces +X -X +Y -Y +Z -Z one after another: the face stack as it is.
    assert np.array_equal(px[..., :3].astype(np.float32), stack)
    back, cube = spheremap.read_texture(path)
    assert cube and np.array_equal(back[0][..., :3], stack.reshape(6, f, f, 3))


def test_bad_textures_are_refused_with_the_reason(tmp_path):
    good = tmp_path / "g.ktx2"
    spheremap.write_texture(good, [np.ones((4, 4, 3), np.float32)])
    b = bytearray(good.read_bytes())
    cases = {
        "trunc.ktx2": bytes(b[:-5]),
        "bc7.ktx2": bytes(b[:12] + struct.pack("<I", 145) + b[16:]),
        "zstd.ktx2": bytes(b[:44] + struct.pack("<I", 2) + b[48:]),
        "empty.dds": b"DDS " + bytes(10),
    }
    for name, data in cases.items():
        p = tmp_path / name
        p.write_bytes(data)
        with pytest.raises(spheremap.DataError, match=name):
            spheremap.read_image(p)
        r = cli("info", p)
        assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1, r.stderr
    with pytest.raises(ValueError, match="levels"):
        spheremap.write_texture(
            tmp_path / "x.ktx2", [np.ones((4, 4, 3), np.float32), np.ones((3, 3, 3), np.float32)]
        )
    with pytest.raises(ValueError, match="levels"):
        spheremap.write_texture(tmp_path / "x.ktx2", [])
    with pytest.raises(spheremap.DataError, match="half"):
        spheremap.write_texture(tmp_path / "x.ktx2", [np.full((2, 2, 3), 1e6, np.float32)], half=True)
    assert not (tmp_path / "x.ktx2").exists()


# -- independent readers: ktx-parse (three.js's KTX2 parser), Babylon.js's DDS reader -------------


def npm_peer(spec, module):
    """The path of `module` (relative to node_modules) of the npm package `spec`, installed
    into target/peers on first use; skips (fails where SPHEREMAP_REQUIRE_NODE=1) without
    Node.js, npm or the package."""
    required = os.environ.get("SPHEREMAP_REQUIRE_NODE") == "1"
    if not (shutil.which("node") and shutil.which("npm")):
        if required:
            pytest.fail("Node.js and npm required (SPHEREMAP_REQUIRE_NODE=1) but missing")
        pytest.skip("Node.js or npm is missing")
    path = os.path.abspath(os.path.join(PEERS, "node_modules", module))
    if not os.path.exists(path):
        p = subprocess.run(
            ["npm", "install", "--no-save", "--no-audit", "--no-fund", "--prefix", PEERS, spec],
            capture_output=True,
            text=True,
        )
        if p.returncode != 0 or not os.path.exists(path):
            if required:
                pytest.fail(f"npm install {spec} failed: {p.stderr[-500:]}")
            pytest.skip(f"npm install {spec} failed")
    return path


def ktx_parse_read(tmp_path, path):
    """What ktx-parse reads in the KTX2 file `path` (READ_KTX2's JSON; each level's data
    written to tmp_path/level{i}.bin). ktx-parse is installed again if a later npm install
    into target/peers pruned it."""
    module = npm_peer(KTX_PARSE, os.path.join("ktx-parse", "dist", "index.mjs"))
    script = tmp_path / "read.mjs"
    script.write_text(READ_KTX2 % json.dumps("file://" + module))
    p = subprocess.run(["node", script, path, tmp_path], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    return json.loads(p.stdout)


@pytest.fixture(scope="module")
def babylon_dds():
    """The path of Babylon.js's DDS reader (`DDSTools`), an ES module."""
    return npm_peer(BABYLON, os.path.join("@babylonjs", "core", "Misc", "dds.js"))


READ_KTX2 = """
import { read } from %s;
import { readFileSync, writeFileSync } from "node:fs";
const [src, out] = process.argv.slice(2);
const c = read(new Uint8Array(readFileSync(src)));
const dfd = c.dataFormatDescriptor[0];
const kv = {};
for (const [k, v] of Object.entries(c.keyValue))
  kv[k] = typeof v === "string" ? v : new TextDecoder().decode(v).replace(/\\0+$/, "");
c.levels.forEach((lv, i) => writeFileSync(`${out}/level${i}.bin`, lv.levelData));
console.log(JSON.stringify({
  vkFormat: c.vkFormat, typeSize: c.typeSize, width: c.pixelWidth, height: c.pixelHeight,
  depth: c.pixelDepth, layers: c.layerCount, faces: c.faceCount, levels: c.levels.length,
  supercompression: c.supercompressionScheme, colorModel: dfd.colorModel,
  transfer: dfd.transferFunction, primaries: dfd.colorPrimaries, kv,
  uncompressed: c.levels.map((lv) => lv.uncompressedByteLength),
}));
"""


def gl_face_dirs(f):
    """World directions of the texel centres of the six faces of a cube of face f, in the order
    +X, -X, +Y, -Y, +Z, -Z, row 0 at t = 0: the cube-map face table of OpenGL 4.6 (Table 8.19),
    which Vulkan shares, (s, t) = ((sc / |ma| + 1) / 2, (tc / |ma| + 1) / 2)."""
    c = 2 * (np.arange(f) + 0.5) / f - 1
    sc, tc = np.meshgrid(c, c)  # sc along a row, tc down the rows
    one = np.ones_like(sc)
    faces = [
        (one, -tc, -sc),  # +X: sc = -rz, tc = -ry
        (-one, -tc, sc),  # -X: sc = +rz, tc = -ry
        (sc, one, tc),  # +Y: sc = +rx, tc = +rz
        (sc, -one, -tc),  # -Y: sc = +rx, tc = -rz
        (sc, -tc, one),  # +Z: sc = +rx, tc = -ry
        (-sc, -tc, -one),  # -Z: sc = -rx, tc = -ry
    ]
    d = np.stack([np.stack(xyz, -1) for xyz in faces])
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def prefiltered_dirs(tmp_path, name, half, f=16):
    """`spheremap prefilter` of an environment whose radiance is its direction (+ 2, to stay
    positive) to the cube texture `name` (faces of f, 3 levels); returns its path."""
    env = latlong_dirs(64, 128).astype(np.float32) + 2
    src = tmp_path / "dirs.exr"
    spheremap.write_image(str(src), env)
    out = tmp_path / name
    args = ["prefilter", src, "-o", out, "--size", f, "--levels", "3", "--samples", "1"]
    p = cli(*args, *(["--half"] if half else []))
    assert p.returncode == 0, p.stderr
    return out


def assert_faces_hold_their_directions(level0):
    """Level 0 (roughness 0) of `prefiltered_dirs` is the environment: each texel of the (6, F,
    F, 4) faces holds its own direction, the one the GL / Vulkan face table gives that texel of
    that face, and not by luck: every other face order or a flip of rows or columns is far off."""
    got = level0[..., :3].astype(np.float64) - 2
    want = gl_face_dirs(level0.shape[1])
    err = np.linalg.norm(got - want, axis=-1)
    # Level 0 is each texel's footprint average (as `convert`), not its centre's value: the
    # mean direction over a corner texel of a 16² face is 0.018 from its centre's.
    assert err.max() < 0.03, err.max()
    assert np.linalg.norm(got - want[[1, 0, 2, 3, 4, 5]], axis=-1).max() > 1
    assert np.linalg.norm(got - want[:, ::-1], axis=-1).max() > 1
    assert np.linalg.norm(got - want[:, :, ::-1], axis=-1).max() > 1


@pytest.mark.parametrize("half", [False, True])
def test_a_cube_ktx2_read_by_ktx_parse_has_its_faces_where_the_format_says(tmp_path, half):
    f = 16
    out = prefiltered_dirs(tmp_path, "dirs.ktx2", half, f)
    meta = ktx_parse_read(tmp_path, out)
    assert meta["vkFormat"] == (97 if half else 109)  # R16G16B16A16_SFLOAT / R32G32B32A32_SFLOAT
    assert meta["typeSize"] == (2 if half else 4)
    assert (meta["width"], meta["height"], meta["depth"], meta["layers"]) == (f, f, 0, 0)
    assert (meta["faces"], meta["levels"], meta["supercompression"]) == (6, 3, 0)
    assert (meta["colorModel"], meta["transfer"], meta["primaries"]) == (1, 1, 1)  # RGBSDA, linear, BT.709
    assert meta["kv"]["KTXorientation"] == "rd"
    ours, cube = spheremap.read_texture(out)
    assert cube
    for i, lv in enumerate(ours):
        fi = f >> i
        raw = (tmp_path / f"level{i}.bin").read_bytes()
        assert len(raw) == meta["uncompressed"][i] == 6 * fi * fi * 4 * (2 if half else 4)
        px = np.frombuffer(raw, np.float16 if half else np.float32).reshape(6, fi, fi, 4)
        # Faces one after another, +X -X +Y -Y +Z -Z, and what spheremap reads back is the same.
        assert np.array_equal(px.astype(np.float32), lv), i
        assert (px[..., 3] == 1).all()
    px = np.frombuffer((tmp_path / "level0.bin").read_bytes(), np.float16 if half else np.float32)
    assert_faces_hold_their_directions(px.reshape(6, f, f, 4))


# Babylon.js's DDS loader: `GetDDSInfo` reads the header, `UploadDDSLevels` walks the faces and
# levels and hands each to the engine's upload, here an engine that records them (float
# textures available, half floats not, so RGBA16F levels are widened by Babylon's own
# FromHalfFloat). Babylon uploads face k to GL's TEXTURE_CUBE_MAP_POSITIVE_X + k.
READ_DDS = """
import { DDSTools } from %s;
import { readFileSync, writeFileSync } from "node:fs";
const [src, out] = process.argv.slice(2);
const buf = readFileSync(src);
const data = new Uint8Array(buf.buffer.slice(buf.byteOffset, buf.byteOffset + buf.byteLength));
const info = DDSTools.GetDDSInfo(data);
const uploads = [];
const engine = {
  getCaps: () => ({ s3tc: null, textureFloat: true, textureFloatLinearFiltering: true,
                    textureHalfFloat: false, textureHalfFloatLinearFiltering: false }),
  _getRGBABufferInternalSizedFormat: () => 0,
  _getUnpackAlignement: () => 4,
  _uploadDataToTextureDirectly: (texture, view, face, lod) => {
    uploads.push({ face, lod, type: view.constructor.name, length: view.length });
    writeFileSync(`${out}/face${face}_level${lod}.bin`,
                  new Uint8Array(view.buffer, view.byteOffset, view.byteLength));
  },
  _uploadCompressedDataToTextureDirectly: () => { throw new Error("compressed"); },
};
const texture = {};
DDSTools.UploadDDSLevels(engine, texture, data, info, true, info.isCube ? 6 : 1);
console.log(JSON.stringify({ info, uploads, textureType: texture.type, format: texture.format }));
"""


def babylon_read(tmp_path, module, path):
    script = tmp_path / "read_dds.mjs"
    script.write_text(READ_DDS % json.dumps("file://" + module))
    p = subprocess.run(["node", script, path, tmp_path], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    return json.loads(p.stdout)


@pytest.mark.parametrize("half", [False, True])
def test_a_cube_dds_read_by_babylon_has_its_faces_where_the_format_says(tmp_path, babylon_dds, half):
    f = 16
    out = prefiltered_dirs(tmp_path, "dirs.dds", half, f)
    meta = babylon_read(tmp_path, babylon_dds, out)
    info = meta["info"]
    assert (info["width"], info["height"], info["mipmapCount"]) == (f, f, 3)
    assert info["isCube"] and info["isFourCC"] and not info["isCompressed"]
    assert info["dxgiFormat"] == (10 if half else 2)  # R16G16B16A16_FLOAT / R32G32B32A32_FLOAT
    assert info["textureType"] == (2 if half else 1)  # Babylon's HALF_FLOAT / FLOAT
    assert meta["textureType"] == 1 and meta["format"] == 5  # read as RGBA float
    # Every face with all its levels, face by face.
    assert [(u["face"], u["lod"]) for u in meta["uploads"]] == [(k, i) for k in range(6) for i in range(3)]
    ours, cube = spheremap.read_texture(out)
    assert cube
    for i, lv in enumerate(ours):
        fi = f >> i
        for k in range(6):
            px = np.fromfile(tmp_path / f"face{k}_level{i}.bin", np.float32).reshape(fi, fi, 4)
            assert np.array_equal(px, lv[k]), (k, i)
            assert (px[..., 3] == 1).all()
    assert_faces_hold_their_directions(
        np.stack([np.fromfile(tmp_path / f"face{k}_level0.bin", np.float32).reshape(f, f, 4) for k in range(6)])
    )


@pytest.mark.parametrize("half", [False, True])
def test_a_2d_dds_mip_chain_read_by_babylon_is_what_was_written(tmp_path, babylon_dds, half):
    rng = np.random.default_rng(7)
    levels = [rng.random((max(1, 8 >> i), max(1, 32 >> i), 4), dtype=np.float32) * 100 for i in range(6)]
    out = tmp_path / "chain.dds"
    spheremap.write_texture(out, levels, half=half)
    meta = babylon_read(tmp_path, babylon_dds, out)
    info = meta["info"]
    assert (info["width"], info["height"], info["mipmapCount"], info["isCube"]) == (32, 8, 6, False)
    assert info["dxgiFormat"] == (10 if half else 2)
    assert [(u["face"], u["lod"]) for u in meta["uploads"]] == [(0, i) for i in range(6)]
    for i, lv in enumerate(levels):
        px = np.fromfile(tmp_path / f"face0_level{i}.bin", np.float32).reshape(lv.shape)
        want = lv.astype(np.float16).astype(np.float32) if half else lv
        assert np.array_equal(px, want), i


def rgb9e5_unpack(words):
    """RGB9E5 texels as EXT_texture_shared_exponent defines them: 9-bit mantissas in bits 0-8,
    9-17, 18-26 and the shared exponent (bias 15) in bits 27-31; value = m * 2^(e - 15 - 9)."""
    w = words.astype(np.uint64)
    e = (w >> 27).astype(np.int64)
    m = np.stack([(w >> s) & 511 for s in (0, 9, 18)], -1).astype(np.float64)
    return m * np.exp2(e - 24)[..., None]


@pytest.mark.parametrize("encode,zstd", [("bc6h", 9), ("rgb9e5", None)])
def test_an_encoded_cube_ktx2_read_by_ktx_parse(tmp_path, encode, zstd):
    """A prefiltered cube written as BC6H blocks (Zstandard-supercompressed) or RGB9E5 texels:
    ktx-parse reads the format, the data format descriptor and the levels; the RGB9E5 levels,
    unpacked here by the extension's formula, are what spheremap reads back; the --json
    report gives each level's power against the uncompressed level."""
    f = 16
    env = latlong_dirs(64, 128).astype(np.float32) + 2
    src = tmp_path / "dirs.exr"
    spheremap.write_image(str(src), env)
    out = tmp_path / "enc.ktx2"
    args = ["prefilter", src, "-o", out, "--size", f, "--levels", "3", "--samples", "1", "--json", "--encode", encode]
    p = cli(*args, *(["--zstd", zstd] if zstd else []))
    assert p.returncode == 0, p.stderr
    report = json.loads(p.stdout)
    assert report["encode"] == encode
    assert len(report["compression"]) == 3
    for lv in report["compression"]:
        assert max(abs(e) for e in lv["power_error"]) < 5e-3, lv
        # A level of a few blocks (here the last: a 4x4 face, one block) pays for its power in
        # RMSLE, within a small multiple of the encoder's own (docs/lighting.md).
        assert lv["clamped"] == 0, lv
        assert lv["rmsle"] < 0.05 or lv["rmsle"] <= 2.5 * lv["rmsle_unrepaired"], lv
    meta = ktx_parse_read(tmp_path, out)
    bc6h = encode == "bc6h"
    # VK_FORMAT_BC6H_UFLOAT_BLOCK / VK_FORMAT_E5B9G9R9_UFLOAT_PACK32; KHR_DF_MODEL_BC6H / RGBSDA.
    assert meta["vkFormat"] == (143 if bc6h else 123)
    assert meta["typeSize"] == (1 if bc6h else 4)
    assert (meta["faces"], meta["levels"], meta["supercompression"]) == (6, 3, 2 if zstd else 0)
    assert (meta["colorModel"], meta["transfer"], meta["primaries"]) == (133 if bc6h else 1, 1, 1)
    ours, cube = spheremap.read_texture(out)
    assert cube
    for i, lv in enumerate(ours):
        fi = f >> i
        size = 6 * (-(-fi // 4)) ** 2 * 16 if bc6h else 6 * fi * fi * 4
        assert meta["uncompressed"][i] == size
        assert lv.shape == (6, fi, fi, 3)
        assert np.isfinite(lv).all() and (lv >= 0).all()
        if not bc6h:
            raw = np.frombuffer((tmp_path / f"level{i}.bin").read_bytes(), "<u4")
            assert np.array_equal(rgb9e5_unpack(raw).reshape(6, fi, fi, 3).astype(np.float32), lv)
    # Level 0 still holds each texel's direction where the GL / Vulkan face table puts it
    # (RGB9E5 to 1/512 of each value; BC6H's blocks to a few percent of these values of 1-3).
    if bc6h:
        err = np.linalg.norm(ours[0] - 2 - gl_face_dirs(f), axis=-1)
        assert err.mean() < 0.08 and err.max() < 0.2, (err.mean(), err.max())
        assert np.linalg.norm(ours[0] - 2 - gl_face_dirs(f)[[1, 0, 2, 3, 4, 5]], axis=-1).max() > 1
    else:
        assert_faces_hold_their_directions(np.concatenate([ours[0], np.ones_like(ours[0][..., :1])], -1))


def test_write_texture_encodes_and_reports_each_level_s_light(tmp_path):
    f = 16
    levels = []
    for i in range(3):
        n = f >> i
        y, x = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
        face = np.stack([1 + 0.5 * np.sin(x / 3.0), 1 + 0.5 * np.cos(y / 4.0), 1 + 0.1 * x / n], -1)
        levels.append(np.repeat(face[None], 6, 0).astype(np.float32) * np.arange(1, 7, dtype=np.float32)[:, None, None, None])
    levels[0][2, 5, 7] = 400.0  # a small bright source
    assert set(spheremap.ENCODINGS) == {"float", "bc6h", "rgb9e5", "rgbd", "rgbm", "uastc-hdr-4x4", "astc-hdr-6x6"}
    for encode in ("float", "bc6h", "rgb9e5"):
        path = tmp_path / f"t_{encode}.ktx2"
        rep = spheremap.write_texture(path, levels, cube=True, encode=encode, zstd=5, mapping="cube")
        back, cube = spheremap.read_texture(path)
        assert cube and len(back) == 3
        if encode == "float":
            assert rep is None
            assert all(np.array_equal(b[..., :3], lv) for b, lv in zip(back, levels))
            continue
        assert [set(r) >= {"power_error", "power_error_unrepaired", "rmsle", "blocks", "repaired"} for r in rep]
        for b, lv, r in zip(back, levels, rep):
            assert b.shape == lv.shape and (b >= 0).all()
            assert max(abs(e) for e in r["power_error"]) < 0.02, r
    with pytest.raises(ValueError, match="encode"):
        spheremap.write_texture(tmp_path / "x.ktx2", levels, cube=True, encode="bc7")
    with pytest.raises(ValueError, match="written in PNG"):
        spheremap.write_texture(tmp_path / "x.ktx2", levels, cube=True, encode="rgbd")
    with pytest.raises(ValueError, match="zstd"):
        spheremap.write_texture(tmp_path / "x.ktx2", levels, cube=True, zstd=0)
    with pytest.raises(ValueError, match="zstd"):
        spheremap.write_texture(tmp_path / "x.dds", levels, cube=True, zstd=3)
    assert not (tmp_path / "x.dds").exists() and not (tmp_path / "x.ktx2").exists()


# The last three.js release with RGBMLoader (r180 removed it).
THREE = "three@0.179.1"

# three.js's own RGBMLoader (examples/jsm/loaders), its parse() on the PNG's bytes (it decodes
# the PNG with the UPNG bundled with three.js and applies r * a * maxRange), as float32.
READ_RGBM = """
import { RGBMLoader } from %s;
import { FloatType } from %s;
import { readFileSync, writeFileSync } from "node:fs";
const [src, out] = process.argv.slice(2);
const buf = readFileSync(src);
const loader = new RGBMLoader().setDataType(FloatType);
const t = loader.parse(buf.buffer.slice(buf.byteOffset, buf.byteOffset + buf.byteLength));
writeFileSync(out, new Uint8Array(t.data.buffer));
console.log(JSON.stringify({ width: t.width, height: t.height, maxRange: loader.maxRange }));
"""


def test_an_rgbm_png_reads_in_three_js_rgbm_loader_as_in_spheremap(tmp_path):
    """An environment written with encode="rgbm" loads in three.js's RGBMLoader (its default
    range, 7) to the values spheremap.read_image returns, and they keep the map's light."""
    loader = npm_peer(THREE, os.path.join("three", "examples", "jsm", "loaders", "RGBMLoader.js"))
    env = (latlong_dirs(32, 64).astype(np.float32) + 1.2) * 2.5  # 0.5 .. 5.5, inside the range
    path = tmp_path / "env_rgbm.png"
    lost = spheremap.write_image(path, env, mapping="latlong", encode="rgbm")
    assert lost["clipped"] == 0
    script = tmp_path / "read_rgbm.mjs"
    three = os.path.join(loader.split(os.sep + "examples" + os.sep)[0], "build", "three.module.js")
    script.write_text(READ_RGBM % (json.dumps("file://" + loader), json.dumps("file://" + three)))
    out = tmp_path / "rgbm.f32"
    p = subprocess.run(["node", script, path, out], capture_output=True, text=True, cwd=os.path.dirname(loader))
    assert p.returncode == 0, p.stderr
    meta = json.loads(p.stdout)
    assert (meta["width"], meta["height"], meta["maxRange"]) == (64, 32, 7)
    theirs = np.frombuffer(out.read_bytes(), np.float32).reshape(32, 64, 4)
    ours = spheremap.read_image(path)
    assert ours.shape == (32, 64, 3)
    # RGBMLoader flips nothing in the data (flipY is for the upload): row 0 is the PNG's top.
    np.testing.assert_allclose(theirs[..., :3], ours, rtol=1e-6, atol=1e-6)
    w = spheremap.texel_solid_angles("latlong", 64, 32)[..., None]
    assert abs((ours * w).sum() / (env * w).sum() - 1) < 5e-3


def test_rgbd_is_babylon_js_s_rgbd(tmp_path):
    """Babylon.js's own definitions (its helperFunctions shader include, from @babylonjs/core)
    are the ones spheremap packs and unpacks by, and an RGBD PNG reads back to them."""
    dds = npm_peer(BABYLON, os.path.join("@babylonjs", "core", "Misc", "dds.js"))
    helpers = os.path.join(os.path.dirname(os.path.dirname(dds)), "Shaders", "ShadersInclude", "helperFunctions.js")
    src = open(helpers).read()
    assert "const float LinearEncodePowerApprox=2.2;" in src
    assert "const float rgbdMaxRange=255.;vec4 toRGBD(vec3 color) {float maxRGB=maxEps(max(color.r,max(color.g,color.b)));float D =max(rgbdMaxRange/maxRGB,1.);D =saturate(floor(D)/255.);vec3 rgb=color.rgb*D;rgb=toGammaSpace(rgb);return vec4(saturate(rgb),D);}" in src
    assert "vec3 fromRGBD(vec4 rgbd) {rgbd.rgb=toLinearSpace(rgbd.rgb);return rgbd.rgb/rgbd.a;}" in src
    env = (latlong_dirs(32, 64).astype(np.float32) + 1.1) * 40  # 4 .. 84
    path = tmp_path / "env_rgbd.png"
    spheremap.write_image(path, env, mapping="latlong", encode="rgbd")
    from PIL import Image

    raw = np.asarray(Image.open(path).convert("RGBA"), np.float64) / 255
    # toRGBD, then fromRGBD, as the two GLSL functions above compute them (GammaEncodePowerApprox
    # = 1 / 2.2), on the values the PNG stores.
    m = np.maximum(env.max(-1), 1e-7)
    d = np.clip(np.floor(np.maximum(255 / m, 1)) / 255, 0, 1)
    np.testing.assert_allclose(raw[..., 3], d, atol=0.5 / 255)
    np.testing.assert_allclose(raw[..., :3], np.clip((env * d[..., None]) ** (1 / 2.2), 0, 1), atol=0.5 / 255 + 1e-7)
    from_rgbd = raw[..., :3] ** 2.2 / raw[..., 3:]
    np.testing.assert_allclose(spheremap.read_image(path), from_rgbd, rtol=1e-5)
    with pytest.raises(ValueError, match="encode"):
        spheremap.write_image(tmp_path / "x.png", env, encode="rgbx")


@pytest.mark.parametrize("encode,model,vk", [("uastc-hdr-4x4", 167, 1000066000), ("astc-hdr-6x6", 162, 1000066004)])
def test_a_basis_universal_hdr_cube_read_by_ktx_parse(tmp_path, encode, model, vk):
    """A prefiltered cube written with Basis Universal's encoder (UASTC HDR 4x4 or ASTC HDR 6x6,
    Zstandard): ktx-parse (three.js's KTX2Loader's parser) reads the format three.js transcodes,
    and spheremap reads every level back."""
    env = latlong_dirs(64, 128).astype(np.float32) + 2
    src = tmp_path / "dirs.exr"
    spheremap.write_image(str(src), env)
    out = tmp_path / "hdr.ktx2"
    p = cli("prefilter", src, "-o", out, "--size", 16, "--levels", "3", "--samples", "1", "--json",
            "--encode", encode, "--zstd", 9)
    if p.returncode != 0 and "no Basis Universal encoder" in p.stderr:
        if os.environ.get("SPHEREMAP_REQUIRE_BASISU") == "1":
            pytest.fail("the Basis Universal encoder is required (SPHEREMAP_REQUIRE_BASISU=1): " + p.stderr)
        pytest.skip("this build has no Basis Universal encoder (feature basisu)")
    assert p.returncode == 0, p.stderr
    report = json.loads(p.stdout)
    assert report["encode"] == encode and len(report["compression"]) == 3
    meta = ktx_parse_read(tmp_path, out)
    assert (meta["vkFormat"], meta["colorModel"], meta["supercompression"]) == (vk, model, 2)
    assert (meta["faces"], meta["levels"], meta["typeSize"]) == (6, 3, 1)
    levels, cube = spheremap.read_texture(out)
    assert cube and [lv.shape for lv in levels] == [(6, 16, 16, 3), (6, 8, 8, 3), (6, 4, 4, 3)]
    assert all(np.isfinite(lv).all() and (lv >= 0).all() for lv in levels)
    err = np.linalg.norm(levels[0] - 2 - gl_face_dirs(16), axis=-1)
    assert err.mean() < 0.15, err.mean()
