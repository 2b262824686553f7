"""The interactive viewer (``spheremap view``) from Python: served from background threads."""

from __future__ import annotations

import html
import os
import webbrowser
from typing import Any

from . import _spheremap as _ext
from ._args import _choice, _vec3
from .names import MAPPINGS

#: The largest file the page accepts when one is dropped on it (the CLI's --max-upload default).
DEFAULT_MAX_UPLOAD: int = _ext.VIEW_MAX_UPLOAD


def _path(v, name: str) -> str | None:
    if v is None:
        return None
    if not isinstance(v, (str, os.PathLike)):
        raise TypeError(f"{name}: expected a path or None, got {type(v).__name__}")
    return os.fspath(v)


class Viewer:
    """A running viewer. ``url`` is its page; ``close()`` (or leaving a ``with`` block) stops it.
    In Jupyter the object shows the page inline."""

    def __init__(self, server: Any) -> None:
        self._server = server

    @property
    def url(self) -> str:
        return str(self._server.url)

    @property
    def running(self) -> bool:
        return bool(self._server.running)

    @property
    def version(self) -> int:
        """1, and one more for each file dropped on the page and accepted."""
        return int(self._server.version)

    def close(self) -> None:
        self._server.close()

    def open(self) -> None:
        """Opens the page in the system's browser."""
        webbrowser.open(self.url)

    def __enter__(self) -> Viewer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"<spheremap.Viewer {self.url} {'running' if self.running else 'closed'}>"

    def _repr_html_(self) -> str:
        u = html.escape(self.url, quote=True)
        return (
            f'<iframe src="{u}" width="100%" height="640" style="border:0" '
            f'title="spheremap viewer"></iframe><p><a href="{u}" target="_blank">{u}</a></p>'
        )


def view(
    mesh: str | os.PathLike[str] | None = None,
    env: str | os.PathLike[str] | None = None,
    matcap: str | os.PathLike[str] | None = None,
    port: int = 0,
    *,
    env_format: str | None = None,
    env_preset: str | None = None,
    env_layout: str | None = None,
    env_look: Any = None,
    env_up: Any = None,
    host: str = "127.0.0.1",
    max_upload: int = DEFAULT_MAX_UPLOAD,
    open_browser: bool = False,
) -> Viewer:
    """Serves the viewer (``spheremap view``; see docs/viewer.md) and returns it.

    mesh: OBJ or glTF/GLB (default: the bundled teapot). env: an environment map file in any
        mapping spheremap reads, read as the CLI reads it (env_format, env_preset, env_layout,
        env_look, env_up: as --env-format, --env-preset, --env-layout, --env-look, --env-up;
        by default the file's note, else lat-long). With neither env nor matcap, the bundled
        HDRI. matcap: a MatCap image.
    port: 0 picks a free one. host: 127.0.0.1 unless another address is wanted (then anyone who
        can reach the machine can see and replace the data). max_upload: bytes a dropped file
        may have. open_browser: also open the page in the system's browser.
    """
    if env_format is not None:
        _choice(env_format, "env_format", MAPPINGS)
    if isinstance(port, bool) or not isinstance(port, int) or not 0 <= port <= 65535:
        raise ValueError(f"port: expected an integer from 0 to 65535, got {port!r}")
    if isinstance(max_upload, bool) or not isinstance(max_upload, int) or max_upload < 1:
        raise ValueError(f"max_upload: expected a positive number of bytes, got {max_upload!r}")
    if not isinstance(host, str) or not host:
        raise ValueError(f"host: expected an address, got {host!r}")
    request = {
        "env_format": env_format,
        "env_preset": env_preset,
        "env_layout": env_layout,
        "env_look": _vec3(env_look, "env_look"),
        "env_up": _vec3(env_up, "env_up"),
        "nonfinite": "error",
    }
    server = _ext.ViewServer(
        mesh=_path(mesh, "mesh"),
        env=_path(env, "env"),
        matcap=_path(matcap, "matcap"),
        request=request,
        host=host,
        port=port,
        max_upload=max_upload,
    )
    v = Viewer(server)
    if open_browser:
        v.open()
    return v
