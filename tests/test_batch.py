"""`spheremap batch` and `spheremap.batch.run`: a recipe over a library of maps on local threads
and on a Dask LocalCluster; outputs byte-identical to the operations run alone; resume after an
interrupted run; bad inputs failing alone; a worker killed mid-run; every kind of recipe mistake."""

import glob
import json
import os
import shutil
import signal
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

import spheremap as sm
from spheremap.batch import Manifest

HDRIS = sorted(glob.glob("testdata/hdri/*.exr"))

RECIPE = """
[[output]]
op = "convert"
name = "{stem}_sphere.exr"
to = "sphere"
size = 64

[[output]]
op = "convert"
name = "previews/{stem}.png"
to = "sphere"
size = 32

[[output]]
op = "convert"
name = "{stem}_faces_{face}.exr"
to = "cube"
size = 16

[[output]]
op = "bake-matcap"
name = "{stem}_matcap.exr"
material = "lambert"
size = 24

[[output]]
op = "prefilter"
name = "{stem}_ggx.ktx2"
to = "cube"
size = 8
levels = 2
method = "sampled"
lobe_samples = 64

[[output]]
op = "irradiance"
name = "{stem}_sh.json"
window = "auto"
"""

# The same outputs made by the CLI one operation at a time: (batch name, CLI arguments).
ALONE = [
    ("{stem}_sphere.exr", ["convert", "{in}", "{out}", "--to", "sphere", "--size", "64"]),
    ("previews/{stem}.png", ["convert", "{in}", "{out}", "--to", "sphere", "--size", "32"]),
    ("{stem}_faces_{face}.exr", ["convert", "{in}", "{out}", "--to", "cube", "--size", "16"]),
    ("{stem}_matcap.exr", ["bake-matcap", "{in}", "-o", "{out}", "--material", "lambert", "--size", "24"]),
    ("{stem}_ggx.ktx2", ["prefilter", "{in}", "-o", "{out}", "--to", "cube", "--size", "8", "--levels", "2",
                         "--method", "sampled", "--lobe-samples", "64"]),
]


def spheremap_cmd():
    exe = os.environ.get("SPHEREMAP_CLI")
    return [exe] if exe else [sys.executable, "-m", "spheremap"]


def cli(*args, **kw):
    return subprocess.run([*spheremap_cmd(), *map(str, args)], capture_output=True, text=True, **kw)


def lines(path):
    with open(path) as f:
        return [json.loads(line) for line in f if line.strip()]


@pytest.fixture(scope="module")
def library(tmp_path_factory):
    """Six small lat-long HDRIs (512×256) that record their mapping."""
    d = tmp_path_factory.mktemp("lib")
    for src in HDRIS[:6]:
        dst = d / os.path.basename(src)
        r = cli("convert", src, dst, "--from", "latlong", "--to", "latlong", "-q")
        assert r.returncode == 0, r.stderr
    return d


@pytest.fixture(scope="module")
def recipe(tmp_path_factory):
    p = tmp_path_factory.mktemp("recipe") / "library.toml"
    p.write_text(RECIPE)
    return p


def no_temp_files(d):
    return [p for p in glob.glob(os.path.join(d, "**", ".*.tmp"), recursive=True)]


def blake3_of(path):
    import blake3

    with open(path, "rb") as f:
        return blake3.blake3(f.read()).hexdigest()


def expand(pattern, stem):
    name = pattern.replace("{stem}", stem)
    if "{face}" in name:
        return [name.replace("{face}", f) for f in ("px", "nx", "py", "ny", "pz", "nz")]
    return [name]


def test_outputs_are_byte_identical_to_each_operation_alone(library, recipe, tmp_path):
    out = tmp_path / "out"
    r = cli("batch", library, "--recipe", recipe, "--out", out, "--json", "--workers", 2)
    assert r.returncode == 0, r.stderr
    s = json.loads(r.stdout)
    assert (s["inputs"], s["done"], s["failed"], s["skipped"], s["cancelled"]) == (6, 6, 0, 0, 0)
    assert s["outputs"] == 6 * (1 + 1 + 6 + 1 + 1 + 1)
    recs = lines(out / "manifest.jsonl")
    assert len(recs) == 6 and all(rec["error"] is None for rec in recs)
    alone = tmp_path / "alone"
    alone.mkdir()
    (alone / "previews").mkdir()
    for rec in recs:
        # The manifest's hashes are BLAKE3 of the bytes (checked with the blake3 package).
        assert rec["input_hash"] == blake3_of(rec["input"])
        for o in rec["outputs"]:
            assert o["hash"] == blake3_of(out / o["path"]), o
        assert rec["worker"] and rec["seconds"] > 0
        stem = os.path.splitext(os.path.basename(rec["input"]))[0]
        for pattern, args in ALONE:
            target = str(alone / pattern.replace("{stem}", stem))
            rr = cli(*[a.replace("{in}", rec["input"]).replace("{out}", target) for a in args], "-q")
            assert rr.returncode == 0, rr.stderr
            for name in expand(pattern, stem):
                a, b = (out / name).read_bytes(), (alone / name).read_bytes()
                assert a == b, name
        # The SH report: what `irradiance --json` prints (less its timing and file list).
        rr = cli("irradiance", rec["input"], "--window", "auto", "--json")
        want = json.loads(rr.stdout)
        got = json.loads((out / f"{stem}_sh.json").read_text())
        for k in ("coefficients", "threejs", "filament", "irradiance_axes", "window", "channels"):
            assert got[k] == want[k], k
    assert not no_temp_files(out)


def test_a_rerun_skips_what_is_done_and_force_redoes_it(library, recipe, tmp_path):
    out = tmp_path / "out"
    r = cli("batch", library, "--recipe", recipe, "--out", out, "--json", "-q")
    assert r.returncode == 0, r.stderr
    before = {p: os.stat(p).st_mtime_ns for p in glob.glob(str(out / "**"), recursive=True) if os.path.isfile(p)}
    r = cli("batch", library, "--recipe", recipe, "--out", out, "--json", "-q")
    s = json.loads(r.stdout)
    assert (s["done"], s["skipped"]) == (0, 6), s
    # A missing output, a changed input and a changed recipe each redo their inputs only.
    first = sorted(glob.glob(str(library / "*.exr")))
    os.remove(out / (os.path.splitext(os.path.basename(first[0]))[0] + "_matcap.exr"))
    lib2 = tmp_path / "lib2"
    shutil.copytree(library, lib2)
    r = cli("batch", library, "--recipe", recipe, "--out", out, "--json", "-q")
    s = json.loads(r.stdout)
    assert (s["done"], s["skipped"]) == (1, 5), s
    for p, t in before.items():
        if "manifest" not in p and os.path.basename(first[0]).split(".")[0] not in p:
            assert os.stat(p).st_mtime_ns == t, p
    changed = tmp_path / "recipe2.toml"
    changed.write_text(RECIPE.replace("size = 24", "size = 20"))
    r = cli("batch", library, "--recipe", changed, "--out", out, "--json", "-q")
    assert json.loads(r.stdout)["done"] == 6
    r = cli("batch", library, "--recipe", changed, "--out", out, "--json", "-q", "--force")
    assert json.loads(r.stdout)["done"] == 6
    # The manifest keeps one line per input after each run's compaction (plus that run's lines).
    r = cli("batch", library, "--recipe", changed, "--out", out, "--json", "-q")
    assert json.loads(r.stdout)["skipped"] == 6
    assert len(lines(out / "manifest.jsonl")) == 6


def test_ctrl_c_stops_cleanly_and_the_rerun_resumes(tmp_path, recipe):
    lib = tmp_path / "lib"
    lib.mkdir()
    for i in range(12):
        r = cli("convert", HDRIS[i % len(HDRIS)], lib / f"m{i:02d}.exr", "--from", "latlong", "--to", "latlong",
                "--yaw", 30 * i, "-q")
        assert r.returncode == 0, r.stderr
    out = tmp_path / "out"
    p = subprocess.Popen([*spheremap_cmd(), "batch", str(lib), "--recipe", str(recipe), "--out", str(out),
                          "--workers", "1", "-q"], stderr=subprocess.PIPE, text=True,
                         # Ctrl-C's default disposition in the child: a shell starts background
                         # jobs with SIGINT ignored, and Python keeps an inherited ignored SIGINT.
                         preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    manifest = out / "manifest.jsonl"
    deadline = time.time() + 60
    while time.time() < deadline and not (manifest.exists() and manifest.read_text().count("\n") >= 2):
        time.sleep(0.05)
    p.send_signal(signal.SIGINT)
    rc = p.wait(timeout=60)
    assert rc == 130, p.stderr.read()
    recs = lines(manifest)
    assert 2 <= len(recs) < 12
    assert not no_temp_files(out)
    # Every file present is complete and recorded: nothing partial, nothing unrecorded.
    recorded = {o["path"] for rec in recs for o in rec["outputs"]}
    present = {os.path.relpath(f, out) for f in glob.glob(str(out / "**"), recursive=True)
               if os.path.isfile(f) and not f.endswith("manifest.jsonl")}
    assert present == recorded
    for rec in recs:
        for o in rec["outputs"]:
            assert blake3_of(out / o["path"]) == o["hash"]
    r = cli("batch", lib, "--recipe", recipe, "--out", out, "--json", "-q")
    assert r.returncode == 0, r.stderr
    s = json.loads(r.stdout)
    assert (s["skipped"], s["done"]) == (len(recs), 12 - len(recs)), s


def test_bad_inputs_fail_alone(library, recipe, tmp_path):
    lib = tmp_path / "lib"
    shutil.copytree(library, lib)
    good = sorted(glob.glob(str(lib / "*.exr")))
    (lib / "garbage.exr").write_bytes(os.urandom(5000))
    data = open(good[0], "rb").read()
    (lib / "truncated.exr").write_bytes(data[: len(data) // 2])
    nan = sm.read_image(good[1])
    nan[10, 20, 1] = np.nan
    sm.write_image(lib / "nan.exr", nan)
    # A sphere map must be square: a 2:1 image that records "sphere" is the wrong shape.
    sm.write_image(lib / "wrongshape.exr", np.ones((32, 64, 3), np.float32), mapping="sphere")
    (lib / "empty.hdr").write_bytes(b"")
    out = tmp_path / "out"
    recipe_latlong = tmp_path / "r.toml"
    # Files without a note are read as lat-long, as the recipe says (unless they record another).
    recipe_latlong.write_text(RECIPE.replace('op = "convert"\n', 'op = "convert"\nfrom = "latlong"\n')
                              .replace('op = "bake-matcap"\n', 'op = "bake-matcap"\nenv_format = "latlong"\n')
                              .replace('op = "prefilter"\n', 'op = "prefilter"\nenv_format = "latlong"\n')
                              .replace('op = "irradiance"\n', 'op = "irradiance"\nenv_format = "latlong"\n'))
    wrong = tmp_path / "r2.toml"
    wrong.write_text(RECIPE)
    r = cli("batch", lib, "--recipe", recipe_latlong, "--out", out, "--json")
    assert r.returncode == 1, r.stderr
    s = json.loads(r.stdout)
    assert (s["done"], s["failed"]) == (7, 4), s
    recs = {os.path.basename(rec["input"]): rec for rec in lines(out / "manifest.jsonl")}
    for bad in ("garbage.exr", "truncated.exr", "nan.exr", "empty.hdr"):
        e = recs[bad]["error"]
        assert e and bad in e and "\n" not in e, (bad, e)
        assert recs[bad]["outputs"] == []
        assert f"spheremap: {e}" in r.stderr
        assert not glob.glob(str(out / (bad.split(".")[0] + "*")))
    assert "NaN" in recs["nan.exr"]["error"]
    assert "not an image" in recs["garbage.exr"]["error"]
    # Read as the sphere map it records, the 2:1 image fails; read as a lat-long (the first
    # recipe forces it), it was fine.
    assert recs["wrongshape.exr"]["error"] is None
    r = cli("batch", lib / "wrongshape.exr", "--recipe", wrong, "--out", out, "--json")
    assert r.returncode == 1
    e = {os.path.basename(x["input"]): x for x in lines(out / "manifest.jsonl")}["wrongshape.exr"]["error"]
    assert "wrongshape.exr" in e and "square" in e, e
    assert not no_temp_files(out)


RECIPE_MISTAKES = [
    ("[[output]]\nop = \"convert\"\nname = \"a.exr\"\nsise = 3\n", "output 1: sise: unknown field"),
    ("[[output]]\nop = \"convert\"\nname = \"a.exr\"\nto = \"spher\"\n", "output 1: to"),
    ("[[output]]\nop = \"convert\"\nname = \"a.exr\"\nsize = -4\n", "output 1"),
    ("[[output]]\nop = \"convert\"\nname = \"a.exr\"\nsize = 100000\n", "output 1: size"),
    ("[[output]]\nop = \"convert\"\nname = \"a.exr\"\nsamples = \"many\"\n", "output 1"),
    ("[[output]]\nop = \"blur\"\nname = \"a.exr\"\n", "output 1: op: unknown operation"),
    ("[[output]]\nname = \"a.exr\"\n", "output 1: op: missing"),
    ("[[output]]\nop = \"convert\"\n", "output 1: name: missing"),
    ("[[output]]\nop = \"convert\"\nname = \"../a.exr\"\n", "output 1: name"),
    ("[[output]]\nop = \"convert\"\nname = \"/tmp/a.exr\"\n", "output 1: name"),
    ("[[output]]\nop = \"convert\"\nname = \"{stem}_{level}.exr\"\n", "unknown placeholder {level}"),
    ("[[output]]\nop = \"convert\"\nname = \"{stem}.txt\"\n", "cannot write this file type"),
    ("[[output]]\nop = \"irradiance\"\nname = \"{stem}.csv\"\n", "cannot write this file type"),
    ("[[output]]\nop = \"irradiance\"\nname = \"{stem}.json\"\nwindow = -1\n", "output 1: window"),
    ("[[output]]\nop = \"bake-matcap\"\nname = \"{stem}.exr\"\nroughness = 2\n", "output 1: roughness"),
    ("[[output]]\nop = \"prefilter\"\nname = \"{stem}.ktx2\"\nmethod = \"magic\"\n", "output 1: method"),
    ("[[output]]\nop = \"convert\"\nname = \"{stem}.exr\"\n[[output]]\nop = \"convert\"\n"
     "name = \"{stem}.exr\"\nto = \"cube\"\n", "output 2: name: \"{stem}.exr\" is also output 1's"),
    ("[[output]]\nop = \"convert\"\nname = \"manifest.jsonl\"\n", "output 1: name"),
    ("[output]\nop = \"convert\"\n", "output: expected a list"),
    ("[[outputs]]\nop = \"convert\"\n", "outputs: unknown key"),
    ("# nothing\n", "no [[output]]"),
    ("", "the file is empty"),
    ("[[output]]\nop = \"convert\"\nname = \"a.exr\"\nsize = [\n", "line 4"),
]


@pytest.mark.parametrize("text, expect", RECIPE_MISTAKES)
def test_recipe_mistakes_are_one_line_before_any_work(library, tmp_path, text, expect):
    rp = tmp_path / "bad.toml"
    rp.write_text(text)
    out = tmp_path / "out"
    r = cli("batch", library, "--recipe", rp, "--out", out)
    assert r.returncode == 2, r.stderr
    msg = r.stderr.strip()
    assert len(msg.splitlines()) == 1 and msg.startswith(f"spheremap: {rp}"), msg
    assert expect in msg, msg
    assert not out.exists()
    with pytest.raises(ValueError, match=str(rp)):
        sm.batch.run(library, rp, out)
    assert not out.exists()


def test_input_and_output_mistakes(library, recipe, tmp_path):
    out = tmp_path / "out"
    for args, expect in [
        ((tmp_path / "nothing.exr",), "no such file"),
        ((str(tmp_path / "*.none"),), "matches no file"),
        ((tmp_path,), "no image files"),
    ]:
        r = cli("batch", *args, "--recipe", recipe, "--out", out)
        assert r.returncode == 2 and expect in r.stderr and r.stderr.count("\n") == 1, r.stderr
    # Two inputs with one stem would make the same files.
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    src = sorted(glob.glob(str(library / "*.exr")))[0]
    shutil.copy(src, tmp_path / "a" / "x.exr")
    shutil.copy(src, tmp_path / "b" / "x.exr")
    r = cli("batch", tmp_path / "a", tmp_path / "b", "--recipe", recipe, "--out", out)
    assert r.returncode == 2 and "would be made from both" in r.stderr, r.stderr
    # An output that would overwrite an input.
    rp = tmp_path / "self.toml"
    rp.write_text('[[output]]\nop = "convert"\nname = "{name}"\nto = "sphere"\n')
    r = cli("batch", tmp_path / "a", "--recipe", rp, "--out", tmp_path / "a")
    assert r.returncode == 2 and "overwrite" in r.stderr, r.stderr
    assert not out.exists()
    # An output folder that is the input folder: the second run does not take the first's
    # outputs for inputs.
    same = tmp_path / "same"
    same.mkdir()
    shutil.copy(src, same / "x.exr")
    rp = tmp_path / "side.toml"
    rp.write_text('[[output]]\nop = "convert"\nname = "{stem}_s.exr"\nto = "sphere"\nsize = 16\n')
    for _ in range(2):
        r = cli("batch", same, "--recipe", rp, "--out", same, "--json", "-q")
        assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["inputs"] == 1 and sorted(os.listdir(same)) == ["manifest.jsonl", "x.exr", "x_s.exr"]
    r = cli("batch", library, "--recipe", recipe, "--out", out, "--workers", 0)
    assert r.returncode == 2 and "--workers" in r.stderr


def test_python_run_locally(library, recipe, tmp_path):
    m = sm.batch.run(library, recipe, tmp_path / "out", workers=2)
    assert isinstance(m, Manifest) and len(m) == 6 and not m.failed
    assert m.summary["done"] == 6 and m.summary["workers"] == 2
    again = sm.batch.run(str(library / "*.exr"), recipe, tmp_path / "out")
    assert again.summary["skipped"] == 6 and len(again) == 6
    # A recipe as a dict: the same checks.
    m2 = sm.batch.run([library], {"output": [{"op": "irradiance", "name": "{index}.json"}]}, tmp_path / "o2")
    assert sorted(os.listdir(tmp_path / "o2")) == [f"{i}.json" for i in range(6)] + ["manifest.jsonl"]
    assert len(Manifest.read(tmp_path / "o2")) == 6 and m2.done
    with pytest.raises(ValueError, match="^recipe: output 1: op"):
        sm.batch.run(library, {"output": [{"op": "x", "name": "a.exr"}]}, tmp_path / "o3")
    with pytest.raises(TypeError, match="^inputs"):
        sm.batch.run(42, recipe, tmp_path / "o3")
    with pytest.raises(TypeError, match="^recipe"):
        sm.batch.run(library, 42, tmp_path / "o3")
    with pytest.raises(FileNotFoundError, match="^recipe"):
        sm.batch.run(library, tmp_path / "none.toml", tmp_path / "o3")
    with pytest.raises(ValueError, match="^workers"):
        sm.batch.run(library, recipe, tmp_path / "o3", workers=0)
    assert not (tmp_path / "o3").exists()


@pytest.fixture(scope="module")
def dask_client():
    import distributed
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None)
    client = distributed.Client(cluster)
    yield client
    client.close()
    cluster.close()


def test_dask_outputs_match_the_local_run(dask_client, library, recipe, tmp_path):
    local = sm.batch.run(library, recipe, tmp_path / "local")
    m = sm.batch.run(library, recipe, tmp_path / "dask", client=dask_client)
    assert m.summary["done"] == 6 and m.summary["workers"] == 2 and not m.failed
    workers = {rec["worker"] for rec in m}
    assert all(w.startswith("tcp://") for w in workers), workers
    for a, b in zip(local, m):
        assert a["input"] == b["input"] and a["input_hash"] == b["input_hash"]
        assert [(o["path"], o["hash"]) for o in a["outputs"]] == [(o["path"], o["hash"]) for o in b["outputs"]]
    again = sm.batch.run(library, recipe, tmp_path / "dask", client=dask_client)
    assert again.summary["skipped"] == 6


def test_a_dask_worker_killed_mid_run(dask_client, recipe, tmp_path):
    lib = tmp_path / "lib"
    lib.mkdir()
    for i in range(10):
        r = cli("convert", HDRIS[i % len(HDRIS)], lib / f"k{i}.exr", "--from", "latlong", "--to", "latlong",
                "--yaw", 20 * i, "-q")
        assert r.returncode == 0
    out = tmp_path / "out"
    pids = dask_client.run(os.getpid)
    victim = sorted(pids.values())[0]
    killer = threading.Thread(target=lambda: (_wait_for_records(out, 1), os.kill(victim, signal.SIGKILL)))
    killer.start()
    m = sm.batch.run(lib, recipe, out, client=dask_client)
    killer.join()
    assert m.summary["done"] == 10 and not m.failed, m.failed
    assert not no_temp_files(out)
    for rec in m:
        for o in rec["outputs"]:
            assert blake3_of(out / o["path"]) == o["hash"]
    dask_client.wait_for_workers(2, timeout=60)


def _wait_for_records(out, n, timeout=60):
    deadline = time.time() + timeout
    while time.time() < deadline:
        p = out / "manifest.jsonl"
        if p.exists() and p.read_text().count("\n") >= n:
            return
        time.sleep(0.02)


def test_cli_dask_local_cluster(library, recipe, tmp_path):
    env = {**os.environ, "SPHEREMAP_PYTHON": sys.executable}
    r = cli("batch", library, "--recipe", recipe, "--out", tmp_path / "out", "--dask", "local:2", "--json", env=env)
    assert r.returncode == 0, r.stderr
    s = json.loads(r.stdout)
    assert (s["done"], s["workers"]) == (6, 2), s
    r = cli("batch", library, "--recipe", recipe, "--out", tmp_path / "out", "--dask", "local:x", env=env)
    assert r.returncode == 2 and "local:N" in r.stderr


def test_the_example_recipe_is_valid():
    """examples/library.toml (the documented recipe) passes the recipe checks; the docs' bench
    recipe too."""
    for path in ("examples/library.toml", "bench/batch.toml"):
        assert sm._spheremap._batch_recipe(path)["output"], path


def test_photos_unwarped_in_batch_match_from_photo_alone(tmp_path):
    """A library of mirror-ball photos (and a fisheye photo) through `from-photo` /
    `from-fisheye` recipes: the same request as the subcommands, the same bytes."""
    env = sm.read_image("testdata/apartment.exr")
    scene = sm.Scene.builtin("mirror-ball", environment=env)
    lib = tmp_path / "photos"
    lib.mkdir()
    for i, eye in enumerate([(0.0, 0.0, 5.0), (0.0, 0.5, 6.0)]):
        sm.write_image(lib / f"ball{i}.exr", scene.preview(eye, (0, 0, 0), fov=30, size=(200, 200), samples=4))
    recipe = tmp_path / "photos.toml"
    recipe.write_text(
        '[[output]]\nop = "from-photo"\nname = "{stem}_sphere.exr"\nfov = 30\nsize = 48\nfill = "smooth"\n\n'
        '[[output]]\nop = "from-photo"\nname = "{stem}_{face}.exr"\nfov = 30\nsize = 16\nto = "cube"\n'
        'reflectance = [0.75, 0.75, 0.75]\n\n'
        '[[output]]\nop = "from-fisheye"\nname = "{stem}_fish.exr"\nmodel = "equidistant"\nfov = 180\nsize = 16\n'
    )
    out = tmp_path / "out"
    r = cli("batch", lib, "--recipe", recipe, "--out", out, "--json")
    assert r.returncode == 0, r.stderr
    s = json.loads(r.stdout)
    assert (s["done"], s["failed"], s["outputs"]) == (2, 0, 2 * (1 + 6 + 1)), s
    for i in range(2):
        src = lib / f"ball{i}.exr"
        alone = tmp_path / f"alone{i}"
        alone.mkdir()
        for args, names in [
            (("from-photo", src, "--fov", 30, "--size", 48, "--fill", "smooth", "-o", alone / "s.exr"),
             [(f"ball{i}_sphere.exr", "s.exr")]),
            (("from-photo", src, "--fov", 30, "--size", 16, "--to", "cube", "--reflectance", 0.75, 0.75, 0.75,
              "-o", alone / "c_{face}.exr"),
             [(f"ball{i}_{f}.exr", f"c_{f}.exr") for f in ("px", "nx", "py", "ny", "pz", "nz")]),
            (("from-fisheye", src, "--model", "equidistant", "--fov", 180, "--size", 16, "-o", alone / "f.exr"),
             [(f"ball{i}_fish.exr", "f.exr")]),
        ]:
            rr = cli(*args, "-q")
            assert rr.returncode == 0, rr.stderr
            for got, want in names:
                assert (out / got).read_bytes() == (alone / want).read_bytes(), got
    # A recipe mistake in a photo operation is refused before any work, naming the key.
    bad = tmp_path / "bad.toml"
    bad.write_text('[[output]]\nop = "from-photo"\nname = "{stem}.exr"\nreflectance = [1, 2]\n')
    r = cli("batch", lib, "--recipe", bad, "--out", tmp_path / "o2")
    assert r.returncode == 2 and "reflectance" in r.stderr and r.stderr.count("\n") == 1, r.stderr
    assert not (tmp_path / "o2" / "manifest.jsonl").exists()
