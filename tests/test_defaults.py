"""Each default is the core's: the CLI's flags take theirs from the core's requests, and every
keyword of a Python function that is a field of the request it fills has the request's default
(or None, which leaves the core's), so the CLI, Python and recipes cannot drift apart."""

import inspect

import pytest

import spheremap as sm
from spheremap import _spheremap as _ext

# (function, the operation whose request it fills, {keyword: the request's field})
CASES = [
    (sm.convert, "convert", {"dst": "to", "dst_preset": "preset"}),
    (sm.bake_matcap, "bake-matcap", {}),
    (sm.prefilter, "prefilter", {}),
    (sm.irradiance_sh, "irradiance", {}),
    (sm.dfg_lut, "dfg", {}),
    (sm.render, "render", {}),
    (sm.analyze, "analyze", {}),
    (sm.info, "info", {}),
    (sm.generate, "generate", {"mapping": "to"}),
    (sm.from_mirror_ball, "from-photo", {}),
    (sm.from_fisheye, "from-fisheye", {}),
    (sm.Scene.preview, "preview", {}),
]


@pytest.mark.parametrize("func, op, renames", CASES, ids=[c[0].__name__ for c in CASES])
def test_a_python_default_is_the_requests(func, op, renames):
    core = _ext.defaults(op)
    fields, checked = [], []
    for name, p in inspect.signature(inspect.unwrap(func)).parameters.items():
        field = renames.get(name, name)
        if field in core:
            fields.append(name)
        if p.default is inspect.Parameter.empty or p.default is None or field not in core:
            continue
        want = core[field]
        if want is None:
            # The core's default depends on the input (its note, its size): Python's arrays have
            # no note, so the keyword says what an array is read as.
            continue
        got = list(p.default) if isinstance(p.default, tuple) else p.default
        assert got == want, f"{func.__name__}({name}={p.default!r}): the core's {op} default is {want!r}"
        checked.append(name)
    # Every function fills its request's fields; most have defaults of their own to compare.
    assert fields and (checked or func is sm.irradiance_sh), (fields, checked)


def test_the_cores_defaults_are_what_the_docs_say():
    assert _ext.defaults("convert")["samples"] == 4
    assert _ext.defaults("bake-matcap")["size"] == 256
    assert _ext.defaults("prefilter")["to"] == "cube"
    assert _ext.defaults("irradiance")["size"] == 32
    with pytest.raises(ValueError, match="^op: unknown operation"):
        _ext.defaults("nope")
