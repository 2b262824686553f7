"""The interactive viewer (``spheremap view``) from Python: served from background threads."""

from __future__ import annotations

import base64
import concurrent.futures
import html
import json
import os
import urllib.parse
import urllib.request
import webbrowser
from typing import Any

from . import _spheremap as _ext
from ._args import _fields, _source_aliases

#: The largest file the page accepts when one is dropped on it (the CLI's --max-upload default).
DEFAULT_MAX_UPLOAD: int = _ext.VIEW_MAX_UPLOAD


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

    def screenshot(
        self,
        path: str | os.PathLike[str] | None = None,
        *,
        chromium: str | os.PathLike[str] | None = None,
        timeout: float = 120.0,
        **params: Any,
    ) -> bytes:
        """The frame the page draws (its canvas, exactly) as PNG bytes (also written to ``path`` when given), drawn by a
        headless Chromium driven by Playwright (``pip install spheremap[viewer]``).

        params: the page's URL parameters (docs/viewer.md), e.g. ``mode="per-pixel"``,
            ``size=(800, 600)``, ``eye=(0, 12, 40)``; a tuple is written comma-separated.
        chromium: the browser to run (default: $SPHEREMAP_CHROMIUM, else /usr/bin/chromium when
            present, else the one Playwright installed). WebGL runs on SwiftShader, so the
            picture does not depend on a GPU.
        """
        try:
            from playwright.sync_api import sync_playwright
        except ImportError as e:
            raise ImportError(f"screenshot: needs Playwright (pip install spheremap[viewer]): {e}") from None
        with urllib.request.urlopen(self.url + "data/scene.json", timeout=timeout) as r:
            known = json.load(r)["url_params"]
        query = {}
        for k, v in params.items():
            if k not in known:
                raise ValueError(f"{k}: not a parameter of the viewer's page (known: {', '.join(known)})")
            query[k] = ",".join(map(str, v)) if isinstance(v, (tuple, list)) else str(v)
        exe = os.fspath(chromium) if chromium is not None else os.environ.get("SPHEREMAP_CHROMIUM")
        if exe is None and os.path.exists("/usr/bin/chromium"):
            exe = "/usr/bin/chromium"
        if exe is not None and not os.path.isfile(exe):
            raise FileNotFoundError(f"chromium: {exe}: no such browser")
        args = ["--use-angle=swiftshader", "--enable-unsafe-swiftshader"]
        if hasattr(os, "geteuid") and os.geteuid() == 0:
            args.append("--no-sandbox")  # Chromium refuses to run as root with its sandbox

        def shoot() -> bytes:
            with sync_playwright() as pw:
                browser = pw.chromium.launch(executable_path=exe, args=args)
                try:
                    page = browser.new_page()
                    errors: list[str] = []
                    page.on("pageerror", lambda e: errors.append(str(e)))
                    page.goto(self.url + "?" + urllib.parse.urlencode(query), timeout=timeout * 1000)
                    page.wait_for_function("window.spheremap !== undefined", timeout=timeout * 1000)
                    page.evaluate("window.spheremap.ready")
                    if errors:
                        raise RuntimeError(f"screenshot: the page failed: {errors[0]}")
                    url = page.evaluate("document.getElementById('view').toDataURL('image/png')")
                    return base64.b64decode(url.split(",", 1)[1])
                finally:
                    browser.close()

        # Playwright's synchronous API refuses a thread with a running event loop (Jupyter's,
        # or another Playwright session's): it runs on a thread of its own.
        with concurrent.futures.ThreadPoolExecutor(1) as pool:
            png = pool.submit(shoot).result()
        if path is not None:
            tmp = os.fspath(path) + ".part"
            with open(tmp, "wb") as f:
                f.write(png)
            os.replace(tmp, path)
        return png

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


@_source_aliases
def view(
    mesh: str | os.PathLike[str] | None = None,
    env: str | os.PathLike[str] | None = None,
    matcap: str | os.PathLike[str] | None = None,
    port: int = 0,
    *,
    src: str | None = None,
    src_preset: str | None = None,
    src_layout: str | None = None,
    src_look: Any = None,
    src_up: Any = None,
    host: str = "127.0.0.1",
    max_upload: int = DEFAULT_MAX_UPLOAD,
    open_browser: bool = False,
) -> Viewer:
    """Serves the viewer (``spheremap view``; see docs/viewer.md) and returns it.

    mesh: OBJ or glTF/GLB (default: the bundled teapot). env: an environment map file in any
        mapping spheremap reads, read as the CLI reads it (src, src_preset, src_layout,
        src_look, src_up: as --env-format, --env-preset, --env-layout, --env-look, --env-up;
        by default the file's note, else lat-long). With neither env nor matcap, the bundled
        HDRI. matcap: a MatCap image.
    port: 0 picks a free one. host: 127.0.0.1 unless another address is wanted (then anyone who
        can reach the machine can see and replace the data). max_upload: bytes a dropped file
        may have. open_browser: also open the page in the system's browser.
    """
    # The environment's fields of the core's EnvRequest, which checks them.
    request = _fields(dict(src=src, src_preset=src_preset, src_layout=src_layout, src_look=src_look, src_up=src_up))
    v = Viewer(_ext.ViewServer(mesh=mesh, env=env, matcap=matcap, request=request, host=host, port=port,
                               max_upload=max_upload))
    if open_browser:
        v.open()
    return v
