"""Argument checks shared by the modules: arrays, sizes, vectors, seeds (each error names the argument)."""

from __future__ import annotations

import functools
import os
from typing import Any

import numpy as np
import numpy.typing as npt

from . import _spheremap as _ext
from .names import SOURCE_ALIASES

_Float = np.float32 | np.float64
_ArrayLike = npt.ArrayLike
_Photo = npt.ArrayLike | str | os.PathLike[str]
_PhotoResult = tuple[npt.NDArray[np.float32], npt.NDArray[np.float32], dict[str, Any]]


def _floats(x, name: str, *, last: tuple[int, ...] | None = None, ndim: int | None = None) -> np.ndarray:
    """float32/float64 C-contiguous view or copy of `x`; ValueError naming `name` otherwise."""
    if isinstance(x, np.ndarray):
        a = x
    else:
        try:
            a = np.asarray(x, dtype=np.float64)
        except (TypeError, ValueError) as e:
            raise ValueError(f"{name}: cannot be read as an array of numbers ({e})") from None
    if a.dtype not in (np.float32, np.float64):
        raise ValueError(f"{name}: dtype {a.dtype} is not supported; pass float32 or float64")
    if ndim is not None and a.ndim != ndim:
        raise ValueError(f"{name}: expected a {ndim}-D array, got shape {a.shape}")
    if a.ndim == 0:
        raise ValueError(f"{name}: expected an array, got a scalar")
    if last is not None and a.shape[-1] not in last:
        want = " or ".join(str(v) for v in last)
        raise ValueError(f"{name}: last dimension must be {want}, got shape {a.shape}")
    return np.ascontiguousarray(a)


def _stack3(a, a_name: str, b, b_name: str) -> np.ndarray:
    """Two (..., 3) arrays broadcast together and stacked to (..., 6), one common dtype."""
    x = _floats(a, a_name, last=(3,))
    y = _floats(b, b_name, last=(3,))
    if x.dtype != y.dtype:
        x, y = x.astype(np.float64), y.astype(np.float64)
    try:
        x, y = np.broadcast_arrays(x, y)
    except ValueError:
        raise ValueError(f"{b_name}: shape {y.shape} does not broadcast with {a_name} {x.shape}") from None
    return np.concatenate([x, y], axis=-1)


def _name(kind: str, value, arg: str) -> str:
    """`value` checked as a name of `kind` by the core's own parser (aliases included)."""
    if not isinstance(value, str):
        raise ValueError(f"{arg}: expected a name, got {value!r}")
    return _ext.check_name(kind=kind, value=value, arg=arg)


def _choice(value, name: str, allowed: tuple[str, ...]) -> str:
    if value not in allowed:
        raise ValueError(f"{name}: {value!r} is not one of {', '.join(allowed)}")
    return value


def _size_any(v, name: str) -> int:
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
        raise ValueError(f"{name}: expected a positive integer, got {v!r}")
    return int(v)


def _vec3(v, name: str):
    if v is None:
        return None
    a = _floats(v, name, last=(3,), ndim=1).astype(np.float64)
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name}: must be finite, got {v!r}")
    return tuple(float(x) for x in a)


def _nonfinite(a: np.ndarray, policy: str, name: str) -> np.ndarray:
    """Applies the NaN/Inf policy ("error", "zero", "keep") to an input array."""
    _name("nonfinite", policy, "nonfinite")
    if policy == "keep":
        return a
    if a.dtype == np.float32 and a.flags.c_contiguous and _ext._all_finite(a):
        return a  # the common case, in one parallel pass (np.isfinite: ~4x slower)
    bad = ~np.isfinite(a)
    if not bad.any():
        return a
    if policy == "zero":
        return np.where(bad, 0, a).astype(a.dtype)
    first = np.unravel_index(int(np.argmax(bad.reshape(-1))), a.shape)
    raise ValueError(
        f"{name}: {int(bad.sum())} NaN/Inf values (the first at index "
        f"{tuple(int(i) for i in first)}); pass nonfinite='zero' or 'keep'"
    )


def _seed(v) -> int:
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 0:
        raise ValueError(f"seed: expected a non-negative integer, got {v!r}")
    return int(v)


def _max_memory(v):
    if v is None:
        return None
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
        raise ValueError(f"max_memory: expected a positive number of bytes, got {v!r}")
    return int(v)


def _finite(v, name: str) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)) or not np.isfinite(v):
        raise ValueError(f"{name}: expected a finite number, got {v!r}")
    return float(v)


def _plain(v):
    """`v` as the native calls read it: numpy scalars and arrays as Python numbers and lists."""
    if isinstance(v, (np.ndarray, np.generic)):
        return v.tolist()
    if isinstance(v, (list, tuple)):
        return [_plain(x) for x in v]
    return v


def _fields(args: dict[str, Any], *, drop: tuple[str, ...] = ()) -> dict[str, Any]:
    """A function's arguments (its `locals()`) as the fields of the core's request it fills,
    which checks them (None: the core's default); `drop`: the arguments that are not fields."""
    return {k: _plain(v) for k, v in args.items() if k not in drop and v is not None}


def _source_aliases(f):
    """`f`, taking the source's keywords in their older spellings too (SOURCE_ALIASES)."""

    @functools.wraps(f)
    def taking_aliases(*args, **kwargs):
        for alias in [k for k in kwargs if k in SOURCE_ALIASES]:
            keyword = SOURCE_ALIASES[alias]
            if keyword in kwargs:
                raise TypeError(f"{f.__name__}() got {keyword!r} twice (as {alias!r})")
            kwargs[keyword] = kwargs.pop(alias)
        return f(*args, **kwargs)

    return taking_aliases
