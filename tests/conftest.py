import json
import math
import os
import subprocess
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.dirname(__file__))


@pytest.fixture(scope="session")
def mesa():
    """The Mesa oracle. Skipped when OSMesa/PyOpenGL are missing, unless SPHEREMAP_REQUIRE_MESA=1
    (CI sets it), in which case their absence fails the run."""
    import mesa_oracle

    try:
        mesa_oracle.renderer()
    except mesa_oracle.MesaUnavailable as e:
        if os.environ.get("SPHEREMAP_REQUIRE_MESA") == "1":
            pytest.fail(f"Mesa oracle required but unavailable: {e}")
        pytest.skip(str(e))
    return mesa_oracle


def cli(*args, cwd=None, env=None):
    """Runs the spheremap CLI as users run it (the installed package's console entry) and
    returns the completed process (text stdout/stderr)."""
    return subprocess.run([sys.executable, "-m", "spheremap", *map(str, args)], capture_output=True, text=True,
                          cwd=cwd, env=env)


def write_recipe(tmp_path, output, hdri):
    """A one-output batch recipe over a library holding `hdri` (a link): returns (library,
    recipe path). `output` is the recipe's output table; a `convert` reads the map as a lat-long
    unless it names the source's mapping, and the output is named after the input with the
    extension its op writes."""
    lib = tmp_path / "lib"
    lib.mkdir()
    os.symlink(os.path.abspath(hdri), lib / os.path.basename(hdri))
    if output["op"] == "convert" and not {"src", "from", "env_format"} & set(output):
        output = {"src": "latlong", **output}
    suffix = ".ktx2" if output["op"] == "prefilter" else ".exr"
    output = {"name": "{stem}" + suffix, **output}
    rp = tmp_path / "recipe.toml"
    rp.write_text("[[output]]\n" + "".join(f"{k} = {json.dumps(v)}\n" for k, v in output.items()))
    return lib, rp


def refused_alike(run_cli, tmp_path, hdri, image, value, arg, cause, cli_args, call, recipe):
    """Checks that `value` is refused by the CLI (`run_cli(*cli_args(value, out))`), by Python
    (`call(value, image)`) and by a batch recipe over `hdri` (`recipe(value)`, its one output)
    with the same message `arg: cause`, each naming the argument as it is spelled there, and
    that nothing is written. Returns the recipe's (library, path)."""
    out = tmp_path / ("out.ktx2" if recipe(value)["op"] == "prefilter" else "out.exr")
    r = run_cli(*cli_args(value, out))
    flag = "--" + arg.replace("_", "-")
    assert r.returncode == 2 and r.stderr.strip() == f"spheremap: {flag}: {cause}", r.stderr
    assert not out.exists()

    with pytest.raises(ValueError) as e:
        call(value, image)
    assert str(e.value) == f"{arg}: {cause}"

    lib, rp = write_recipe(tmp_path, recipe(value), hdri)
    r = run_cli("batch", lib, "--recipe", rp, "--out", tmp_path / "made")
    assert r.returncode == 2, r.stderr
    assert r.stderr.strip() == f"spheremap: {rp}: output 1: {arg}: {cause}", r.stderr
    assert not (tmp_path / "made").exists()
    return lib, rp


def psnr(a, b, mask=None):
    """PSNR in dB of `a` against the reference `b` (over `mask` if given), the peak taken as the
    reference's 99.9th percentile and both clipped to [0, peak] (HDR-safe)."""
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    if mask is not None:
        a, b = a[mask], b[mask]
    peak = float(np.percentile(b, 99.9))
    mse = float(np.mean((np.clip(a, 0, peak) - np.clip(b, 0, peak)) ** 2))
    return 10 * math.log10(peak * peak / mse)


def write_glb(path, positions, normals, indices, nodes, scene_nodes):
    """A minimal glTF 2.0 binary: one mesh (one triangle primitive), the given nodes."""
    import struct

    pos = np.asarray(positions, np.float32).tobytes()
    nrm = np.asarray(normals, np.float32).tobytes()
    idx = np.asarray(indices, np.uint32).tobytes()
    blob = pos + nrm + idx
    p = np.asarray(positions, np.float32)
    doc = {
        "asset": {"version": "2.0"},
        "buffers": [{"byteLength": len(blob)}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": len(pos)},
            {"buffer": 0, "byteOffset": len(pos), "byteLength": len(nrm)},
            {"buffer": 0, "byteOffset": len(pos) + len(nrm), "byteLength": len(idx)},
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": len(p), "type": "VEC3",
             "min": p.min(0).tolist(), "max": p.max(0).tolist()},
            {"bufferView": 1, "componentType": 5126, "count": len(p), "type": "VEC3"},
            {"bufferView": 2, "componentType": 5125, "count": len(indices), "type": "SCALAR"},
        ],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2}]}],
        "nodes": nodes,
        "scenes": [{"nodes": scene_nodes}],
        "scene": 0,
    }
    js = json.dumps(doc).encode()
    js += b" " * (-len(js) % 4)
    blob += b"\0" * (-len(blob) % 4)
    body = struct.pack("<II", len(js), 0x4E4F534A) + js + struct.pack("<II", len(blob), 0x004E4942) + blob
    path.write_bytes(struct.pack("<III", 0x46546C67, 2, 12 + len(body)) + body)
