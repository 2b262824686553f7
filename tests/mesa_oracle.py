"""Mesa (OSMesa, llvmpipe/softpipe) as an oracle for GL_SPHERE_MAP texgen.

Renders points in GL_FEEDBACK mode and reads back the texture coordinates Mesa generated,
with a texture enabled on unit 0 (or Mesa skips texgen), texture matrix identity,
projection diag(0,0,0,±1) so that no vertex is clipped (the sign follows each vertex's eye w),
glFeedbackBuffer(GL_4D_COLOR_TEXTURE). PyOpenGL's glRenderMode wrapper crashes, so the raw
function is used.
"""

from __future__ import annotations

import os

os.environ.setdefault("PYOPENGL_PLATFORM", "osmesa")

import ctypes

import numpy as np


class MesaUnavailable(RuntimeError):
    pass


_ctx = None


def _context():
    global _ctx
    if _ctx is not None:
        return _ctx
    try:
        from OpenGL import GL, osmesa
        from OpenGL import arrays  # noqa: F401
    except Exception as e:  # ImportError, or libOSMesa missing
        raise MesaUnavailable(f"PyOpenGL/OSMesa not available: {e}") from e
    ctx = osmesa.OSMesaCreateContextExt(osmesa.OSMESA_RGBA, 24, 0, 0, None)
    if not ctx:
        raise MesaUnavailable("OSMesaCreateContextExt failed")
    buf = (ctypes.c_ubyte * (4 * 4 * 4))()
    if not osmesa.OSMesaMakeCurrent(ctx, buf, GL.GL_UNSIGNED_BYTE, 4, 4):
        raise MesaUnavailable("OSMesaMakeCurrent failed")
    tex = GL.glGenTextures(1)
    GL.glBindTexture(GL.GL_TEXTURE_2D, tex)
    GL.glTexImage2D(GL.GL_TEXTURE_2D, 0, GL.GL_RGBA, 1, 1, 0, GL.GL_RGBA, GL.GL_UNSIGNED_BYTE, b"\xff\xff\xff\xff")
    GL.glEnable(GL.GL_TEXTURE_2D)
    for coord, gen in ((GL.GL_S, GL.GL_TEXTURE_GEN_S), (GL.GL_T, GL.GL_TEXTURE_GEN_T)):
        GL.glTexGeni(coord, GL.GL_TEXTURE_GEN_MODE, GL.GL_SPHERE_MAP)
        GL.glEnable(gen)
    GL.glMatrixMode(GL.GL_TEXTURE)
    GL.glLoadIdentity()
    _ctx = (ctx, buf, GL)
    return _ctx


def renderer() -> str:
    _, _, GL = _context()
    return f"{GL.glGetString(GL.GL_RENDERER).decode()} / {GL.glGetString(GL.GL_VERSION).decode()}"


def mesa_sphere_texgen(positions: np.ndarray, normals: np.ndarray, modelview: np.ndarray, normalize: str) -> np.ndarray:
    """(N,4) positions, (N,3) normals, (4,4) math-convention modelview -> (N,2) float32 (s,t)."""
    from OpenGL.raw.GL.VERSION.GL_1_0 import glRenderMode as raw_render_mode

    _, _, GL = _context()
    positions = np.asarray(positions, np.float32)
    normals = np.asarray(normals, np.float32)
    n = len(positions)
    mv = np.asarray(modelview, np.float32)
    if normalize == "on":
        GL.glEnable(GL.GL_NORMALIZE)
        GL.glDisable(GL.GL_RESCALE_NORMAL)
    elif normalize == "rescale":
        GL.glDisable(GL.GL_NORMALIZE)
        GL.glEnable(GL.GL_RESCALE_NORMAL)
    else:
        GL.glDisable(GL.GL_NORMALIZE)
        GL.glDisable(GL.GL_RESCALE_NORMAL)
    GL.glMatrixMode(GL.GL_MODELVIEW)
    GL.glLoadMatrixf(np.ascontiguousarray(mv.T).ravel())  # GL wants column-major
    eye_w = positions.astype(np.float64) @ mv.astype(np.float64)[3]
    out = np.full((n, 2), np.nan, np.float32)
    per = 13  # token + 4 coords + 4 colour + 4 texcoords
    for sign in (1.0, -1.0):
        idx = np.nonzero(np.sign(eye_w) == sign)[0]
        if len(idx) == 0:
            continue
        GL.glMatrixMode(GL.GL_PROJECTION)
        GL.glLoadMatrixf(np.diag([0.0, 0.0, 0.0, sign]).astype(np.float32).T.ravel())
        chunk = 4096
        for start in range(0, len(idx), chunk):
            sel = idx[start:start + chunk]
            fb = (GL.GLfloat * (per * len(sel) + 16))()
            GL.glFeedbackBuffer(len(fb), GL.GL_4D_COLOR_TEXTURE, fb)
            raw_render_mode(GL.GL_FEEDBACK)
            GL.glBegin(GL.GL_POINTS)
            for i in sel:
                GL.glNormal3f(*normals[i])
                GL.glVertex4f(*positions[i])
            GL.glEnd()
            count = raw_render_mode(GL.GL_RENDER)
            vals = np.frombuffer(fb, np.float32, count)
            if count != per * len(sel):
                raise RuntimeError(f"feedback returned {count} values for {len(sel)} points")
            rec = vals.reshape(len(sel), per)
            if not np.all(rec[:, 0] == GL.GL_POINT_TOKEN):
                raise RuntimeError("unexpected feedback token")
            out[sel] = rec[:, 9:11]
    return out


class _OwnContext:
    """A separate OSMesa context over a fresh (w, h) buffer of `ctype` for one draw; on exit it
    is destroyed and the texgen oracle's context made current again."""

    def __init__(self, w, h, ctype, gl_type, depth):
        self.w, self.h, self.ctype, self.gl_type, self.depth = w, h, ctype, gl_type, depth

    def __enter__(self):
        from OpenGL import GL, osmesa

        _context()  # raises MesaUnavailable when OSMesa is missing
        self.ctx = osmesa.OSMesaCreateContextExt(osmesa.OSMESA_RGBA, self.depth, 0, 0, None)
        if not self.ctx:
            raise MesaUnavailable("OSMesaCreateContextExt failed")
        self.buf = (self.ctype * (self.w * self.h * 4))()
        if not osmesa.OSMesaMakeCurrent(self.ctx, self.buf, self.gl_type, self.w, self.h):
            osmesa.OSMesaDestroyContext(self.ctx)
            raise MesaUnavailable("OSMesaMakeCurrent failed")
        GL.glViewport(0, 0, self.w, self.h)
        return self

    def pixels(self, dtype):
        """The buffer, (h, w, 4), row 0 = the bottom (OSMesa's default)."""
        return np.frombuffer(self.buf, dtype).reshape(self.h, self.w, 4).copy()

    def __exit__(self, *exc):
        from OpenGL import GL, osmesa

        osmesa.OSMesaDestroyContext(self.ctx)
        if _ctx is not None:
            osmesa.OSMesaMakeCurrent(_ctx[0], _ctx[1], GL.GL_UNSIGNED_BYTE, 4, 4)
        return False


def mesa_render_sphere_map(positions, normals, triangles, modelview, projection, texture, size,
                           background=(0, 0, 0)) -> np.ndarray:
    """Draws triangles with OpenGL's fixed-function GL_SPHERE_MAP path in Mesa: texgen on S and
    T, GL_NORMALIZE, GL_REPLACE, a GL_LINEAR RGBA8 texture without mipmaps clamped to the edge,
    depth test GL_LESS, no lighting, no culling. `texture`: (H, W, 4) uint8 with row 0 at the top
    (t = 1); returns (height, width, 4) uint8 with row 0 at the top. Uses its own context."""
    from OpenGL import GL

    w, h = size
    with _OwnContext(w, h, ctypes.c_ubyte, GL.GL_UNSIGNED_BYTE, 24) as c:
        GL.glClearColor(background[0] / 255, background[1] / 255, background[2] / 255, 1.0)
        GL.glClearDepth(1.0)
        GL.glClear(GL.GL_COLOR_BUFFER_BIT | GL.GL_DEPTH_BUFFER_BIT)
        GL.glEnable(GL.GL_DEPTH_TEST)
        GL.glDepthFunc(GL.GL_LESS)
        GL.glDisable(GL.GL_LIGHTING)
        GL.glDisable(GL.GL_CULL_FACE)
        GL.glDisable(GL.GL_DITHER)
        GL.glEnable(GL.GL_NORMALIZE)
        tex = GL.glGenTextures(1)
        GL.glBindTexture(GL.GL_TEXTURE_2D, tex)
        for p, v in ((GL.GL_TEXTURE_MIN_FILTER, GL.GL_LINEAR), (GL.GL_TEXTURE_MAG_FILTER, GL.GL_LINEAR),
                     (GL.GL_TEXTURE_WRAP_S, GL.GL_CLAMP_TO_EDGE), (GL.GL_TEXTURE_WRAP_T, GL.GL_CLAMP_TO_EDGE)):
            GL.glTexParameteri(GL.GL_TEXTURE_2D, p, v)
        GL.glPixelStorei(GL.GL_UNPACK_ALIGNMENT, 1)
        t = np.ascontiguousarray(np.asarray(texture, np.uint8)[::-1])  # GL row 0 is t = 0
        GL.glTexImage2D(GL.GL_TEXTURE_2D, 0, GL.GL_RGBA8, t.shape[1], t.shape[0], 0, GL.GL_RGBA,
                        GL.GL_UNSIGNED_BYTE, t)
        GL.glTexEnvi(GL.GL_TEXTURE_ENV, GL.GL_TEXTURE_ENV_MODE, GL.GL_REPLACE)
        GL.glEnable(GL.GL_TEXTURE_2D)
        for coord, gen in ((GL.GL_S, GL.GL_TEXTURE_GEN_S), (GL.GL_T, GL.GL_TEXTURE_GEN_T)):
            GL.glTexGeni(coord, GL.GL_TEXTURE_GEN_MODE, GL.GL_SPHERE_MAP)
            GL.glEnable(gen)
        GL.glMatrixMode(GL.GL_TEXTURE)
        GL.glLoadIdentity()
        GL.glMatrixMode(GL.GL_PROJECTION)
        GL.glLoadMatrixd(np.ascontiguousarray(np.asarray(projection, np.float64).T).ravel())
        GL.glMatrixMode(GL.GL_MODELVIEW)
        GL.glLoadMatrixd(np.ascontiguousarray(np.asarray(modelview, np.float64).T).ravel())
        pos = np.ascontiguousarray(positions, np.float32)
        nrm = np.ascontiguousarray(normals, np.float32)
        idx = np.ascontiguousarray(triangles, np.uint32).ravel()
        GL.glEnableClientState(GL.GL_VERTEX_ARRAY)
        GL.glEnableClientState(GL.GL_NORMAL_ARRAY)
        GL.glVertexPointer(3, GL.GL_FLOAT, 0, pos)
        GL.glNormalPointer(GL.GL_FLOAT, 0, nrm)
        GL.glDrawElements(GL.GL_TRIANGLES, len(idx), GL.GL_UNSIGNED_INT, idx)
        GL.glFinish()
        return c.pixels(np.uint8)[::-1]  # row 0 at the top


def mesa_run_fragment(source: str, inputs: list, size) -> np.ndarray:
    """Runs a GLSL fragment shader over a (width, height) float framebuffer in Mesa and returns
    its output (height, width, 4) float32, row 0 = the bottom of the framebuffer (y = 0).
    `inputs`: (H, W, 3) float32 arrays bound as RGB32F textures to units 0, 1, ... and uniforms
    `in0`, `in1`, ... (read them with texelFetch(inK, ivec2(gl_FragCoord.xy), 0)); a 4-D entry
    (H, W, 4) float32 named by a tuple (name, array, filter) binds an RGBA32F texture with
    GL_LINEAR (True) or GL_NEAREST filtering under that name. Uses its own context."""
    from OpenGL import GL

    w, h = size
    with _OwnContext(w, h, ctypes.c_float, GL.GL_FLOAT, 0) as c:
        GL.glClampColor(GL.GL_CLAMP_FRAGMENT_COLOR, GL.GL_FALSE)
        sh = GL.glCreateShader(GL.GL_FRAGMENT_SHADER)
        GL.glShaderSource(sh, source)
        GL.glCompileShader(sh)
        if not GL.glGetShaderiv(sh, GL.GL_COMPILE_STATUS):
            raise RuntimeError("GLSL compile failed: " + GL.glGetShaderInfoLog(sh).decode())
        prog = GL.glCreateProgram()
        GL.glAttachShader(prog, sh)
        GL.glLinkProgram(prog)
        if not GL.glGetProgramiv(prog, GL.GL_LINK_STATUS):
            raise RuntimeError("GLSL link failed: " + GL.glGetProgramInfoLog(prog).decode())
        GL.glUseProgram(prog)
        for unit, item in enumerate(inputs):
            name, arr, linear = item if isinstance(item, tuple) else (f"in{unit}", item, False)
            arr = np.ascontiguousarray(arr, np.float32)
            fmt, ifmt = (GL.GL_RGB, GL.GL_RGB32F) if arr.shape[2] == 3 else (GL.GL_RGBA, GL.GL_RGBA32F)
            GL.glActiveTexture(GL.GL_TEXTURE0 + unit)
            tex = GL.glGenTextures(1)
            GL.glBindTexture(GL.GL_TEXTURE_2D, tex)
            filt = GL.GL_LINEAR if linear else GL.GL_NEAREST
            for p, v in ((GL.GL_TEXTURE_MIN_FILTER, filt), (GL.GL_TEXTURE_MAG_FILTER, filt),
                         (GL.GL_TEXTURE_WRAP_S, GL.GL_CLAMP_TO_EDGE), (GL.GL_TEXTURE_WRAP_T, GL.GL_CLAMP_TO_EDGE)):
                GL.glTexParameteri(GL.GL_TEXTURE_2D, p, v)
            GL.glPixelStorei(GL.GL_UNPACK_ALIGNMENT, 1)
            GL.glTexImage2D(GL.GL_TEXTURE_2D, 0, ifmt, arr.shape[1], arr.shape[0], 0, fmt, GL.GL_FLOAT, arr)
            GL.glUniform1i(GL.glGetUniformLocation(prog, name), unit)
        GL.glMatrixMode(GL.GL_PROJECTION)
        GL.glLoadIdentity()
        GL.glMatrixMode(GL.GL_MODELVIEW)
        GL.glLoadIdentity()
        GL.glBegin(GL.GL_QUADS)
        for x, y in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
            GL.glVertex2f(x, y)
        GL.glEnd()
        GL.glFinish()
        return c.pixels(np.float32)
