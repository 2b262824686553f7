"""What the modules share: the types of their signatures, and how they hand their arguments to
the native module, which checks them (each error names the argument)."""

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


def _name(kind: str, value, arg: str) -> str:
    """`value` checked as a name of `kind` by the core's own parser (aliases included)."""
    if not isinstance(value, str):
        raise ValueError(f"{arg}: expected a name, got {value!r}")
    return _ext.check_name(kind=kind, value=value, arg=arg)


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
