#!/usr/bin/env python3
"""Writes the bad-input corpus next to this script (the files are committed; run this only to
change them). Each file is broken in one stated way; tests/test_bad_inputs.py feeds them to the
CLI and the Python API. Needs numpy, Pillow and the repository's testdata/."""

import os
import struct
import zlib

import numpy as np
from PIL import Image

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
rng = np.random.default_rng(7)


def put(name, data: bytes):
    with open(os.path.join(HERE, name), "wb") as f:
        f.write(data)


def png_bytes(a):
    import io
    b = io.BytesIO()
    Image.fromarray(a).save(b, format="PNG")
    return b.getvalue()


def jpeg_bytes(a):
    import io
    b = io.BytesIO()
    Image.fromarray(a).save(b, format="JPEG")
    return b.getvalue()


def chunk(kind, data):
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))


img = (rng.random((32, 64, 3)) * 255).astype(np.uint8)
exr = open(os.path.join(ROOT, "testdata", "apartment.exr"), "rb").read()
png = png_bytes(img)
jpg = jpeg_bytes(img)

# Truncated and garbage files of every format.
put("truncated.exr", exr[:300])
put("garbage.exr", rng.bytes(1024))
put("truncated.png", png[: len(png) // 2])
put("truncated.jpg", jpg[: len(jpg) // 2])
put("garbage.webp", b"RIFF\x20\x00\x00\x00WEBPVP8 " + rng.bytes(64))
put("empty.png", b"")
hdr_head = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 32 +X 64\n"
put("truncated.hdr", hdr_head + rng.bytes(100))
put("garbage.hdr", b"#?RADIANCE\n" + rng.bytes(200))
put("truncated.pfm", b"PF\n64 32\n-1.0\n" + np.zeros(100, np.float32).tobytes())
# Absurd headers: dimensions far over the limits, nothing behind them.
put("absurd.hdr", b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1000000 +X 1000000\n" + rng.bytes(64))
put("absurd.pfm", b"PF\n200000 200000\n-1.0\n" + rng.bytes(64))
ihdr = struct.pack(">IIBBBBB", 200000, 200000, 8, 2, 0, 0, 0)
put("absurd.png", b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IEND", b""))
# A well-formed PNG whose name says EXR: read by content (works; `info` reports the mismatch).
put("png_named.exr", png_bytes(img[:32, :32]))
# A sphere map must be square.
put("nonsquare_sphere.png", png)
# Cube faces that disagree in size.
for f in ("px", "nx", "py", "ny", "pz"):
    put(f"faces_{f}.png", png_bytes(img[:16, :16]))
put("faces_nz.png", png_bytes(img[:8, :8]))
# Broken meshes.
put("index_out_of_range.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n")
put("garbage.obj", b"v 0 0 0\nf 1 2 3\n" + rng.bytes(256))
put("no_geometry.obj", b"# nothing here\n")
put("bad_mtl.obj", b"mtllib bad_mtl.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl m\nf 1 2 3\n")
put("bad_mtl.mtl", b"newmtl m\nKd 1 2\n")  # two numbers where three are due (tobj panicked)
put("broken.gltf", b'{"asset": {"version": "2.0"}, "meshes": [')
put("missing_buffer.gltf", b'{"asset":{"version":"2.0"},"buffers":[{"byteLength":12,"uri":"nope.bin"}]}')
print("corpus written to", HERE)
