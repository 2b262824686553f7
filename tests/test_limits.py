"""The core's one table of limits, seen from every entry point: `spheremap limits --json`,
Python's `spheremap.limits()` and docs/limits.md list the same rows, and a value one over a limit
is refused by the CLI, by Python and by a batch recipe with the same message, each naming the
argument as it is spelled there (`--max-samples`, `max_samples`)."""

import json
import os
import re
import subprocess
import sys

import numpy as np
import pytest
from conftest import refused_alike

import spheremap as sm

HDRI = "testdata/apartment.exr"
LIMITS = sm.limits()


def spheremap_cmd():
    exe = os.environ.get("SPHEREMAP_CLI")
    return [exe] if exe else [sys.executable, "-m", "spheremap"]


def cli(*args):
    return subprocess.run([*spheremap_cmd(), *map(str, args)], capture_output=True, text=True)


def over(name):
    return int(LIMITS[name]["value"]) + 1


def test_cli_python_and_docs_list_the_same_table():
    r = cli("limits", "--json")
    assert r.returncode == 0, r.stderr
    rows = json.loads(r.stdout)
    assert {x.pop("name"): x for x in rows} == LIMITS
    text = cli("limits").stdout
    assert all(line.split()[0] in LIMITS for line in text.splitlines()) and len(text.splitlines()) == len(LIMITS)
    doc = open("docs/limits.md").read()
    documented = {}
    for m in re.finditer(r"^\| `(\w+)` \| ([\d,.e]+) to ([\d,.e]+) \| (\w+) \|", doc, re.M):
        documented[m[1]] = (float(m[2].replace(",", "")), float(m[3].replace(",", "")), m[4])
    assert documented == {k: (v["min"], v["value"], v["unit"]) for k, v in LIMITS.items()}
    assert LIMITS["map_size"]["value"] == 32768 and LIMITS["samples"]["value"] == 65536


def test_the_environment_replaces_the_defaults_it_names():
    env = dict(os.environ, SPHEREMAP_MAX_MEMORY="2G", SPHEREMAP_MAX_PIXELS="1000")
    r = subprocess.run([*spheremap_cmd(), "limits", "--json"], capture_output=True, text=True, env=env)
    rows = {x["name"]: x for x in json.loads(r.stdout)}
    assert rows["memory"]["value"] == 2 << 30 and rows["memory"]["env"] == "SPHEREMAP_MAX_MEMORY"
    assert rows["image_pixels"]["value"] == 1000
    assert rows["map_size"]["value"] == LIMITS["map_size"]["value"]


# (limit, (the argument, the cause) for a value n, CLI arguments, the Python call, the recipe's output)
CASES = [
    (
        "map_size",
        lambda n: ("size", f"{n} is out of range 1..={n - 1}"),
        lambda n, out: ["convert", HDRI, out, "--from", "latlong", "--to", "sphere", "--size", n],
        lambda n, img: sm.convert(img, "latlong", "sphere", size=n),
        lambda n: {"op": "convert", "to": "sphere", "size": n},
    ),
    (
        "map_size",
        lambda n: ("size", f"{n} is out of range 1..={n - 1}"),
        lambda n, out: ["bake-matcap", HDRI, "-o", out, "--size", n],
        lambda n, img: sm.bake_matcap(img, size=n),
        lambda n: {"op": "bake-matcap", "size": n},
    ),
    (
        "map_size",
        lambda n: ("size", f"{n} is out of range 1..={n - 1}"),
        lambda n, out: ["prefilter", HDRI, "-o", out, "--size", n],
        lambda n, img: sm.prefilter(img, size=n),
        lambda n: {"op": "prefilter", "size": n},
    ),
    (
        "samples",
        lambda n: ("samples", f"{n} is out of range 1..={n - 1}"),
        lambda n, out: ["convert", HDRI, out, "--from", "latlong", "--to", "sphere", "--size", 8, "--samples", n],
        lambda n, img: sm.convert(img, "latlong", "sphere", size=8, samples=n),
        lambda n: {"op": "convert", "to": "sphere", "size": 8, "samples": n},
    ),
    (
        "samples",
        lambda n: ("max_samples", f"{n} is out of range 1..={n - 1}"),
        lambda n, out: ["bake-matcap", HDRI, "-o", out, "--size", 8, "--max-samples", n],
        lambda n, img: sm.bake_matcap(img, size=8, max_samples=n),
        lambda n: {"op": "bake-matcap", "size": 8, "max_samples": n},
    ),
    (
        "lobe_samples",
        lambda n: ("lobe_samples", f"{n} is out of range 1..={n - 1}"),
        lambda n, out: ["prefilter", HDRI, "-o", out, "--size", 8, "--method", "sampled", "--lobe-samples", n],
        lambda n, img: sm.prefilter(img, size=8, method="sampled", lobe_samples=n),
        lambda n: {"op": "prefilter", "size": 8, "method": "sampled", "lobe_samples": n},
    ),
]


@pytest.fixture(scope="module")
def hdri():
    return sm.read_image(HDRI)


@pytest.mark.parametrize("case", range(len(CASES)))
def test_one_over_a_limit_is_refused_alike_everywhere(case, hdri, tmp_path):
    name, message, cli_args, call, recipe = CASES[case]
    n = over(name)
    arg, cause = message(n)
    expect = f"{arg}: {cause}"
    lib, rp = refused_alike(cli, tmp_path, HDRI, hdri, n, arg, cause, cli_args, call, recipe)
    with pytest.raises(ValueError) as e:
        sm.batch.run(lib, rp, tmp_path / "made")
    assert str(e.value).endswith(f"output 1: {expect}")


def test_the_memory_limit_is_one_rule_everywhere(hdri, tmp_path):
    out = tmp_path / "big.exr"
    r = cli("convert", HDRI, out, "--from", "latlong", "--to", "sphere", "--size", 4096, "--max-memory", "1M")
    assert r.returncode == 2 and "over the memory limit of 0.0 GiB" in r.stderr, r.stderr
    assert not out.exists()
    with pytest.raises(sm.LimitError, match="over the memory limit of 0.0 GiB"):
        sm.convert(hdri, "latlong", "sphere", size=4096, max_memory=1 << 20)
    env = dict(os.environ, SPHEREMAP_MAX_MEMORY="1M")
    r = subprocess.run(
        [*spheremap_cmd(), "convert", HDRI, out, "--from", "latlong", "--to", "sphere", "--size", "4096"],
        capture_output=True, text=True, env=env,
    )
    assert r.returncode == 2 and "over the memory limit" in r.stderr, r.stderr
    assert not out.exists()


def test_python_reports_the_limit_of_a_solid_angle_canvas():
    side = int(LIMITS["image_side"]["value"])
    with pytest.raises(ValueError, match=rf"^width: {side + 1} is out of range 1..={side}$"):
        sm.texel_solid_angles("sphere", side + 1)
    assert np.isclose(sm.texel_solid_angles("sphere", 8).sum(), np.pi * 4, rtol=1e-6)
