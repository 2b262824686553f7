#!/usr/bin/env bash
# The README's test command: installs what the tests need, builds, and runs every test
# (Rust unit/property/integration tests, then the Python suite, the Mesa oracle included).
# Usage: bash scripts/test.sh          (from the repository root)
set -euo pipefail
cd "$(dirname "$0")/.."

# Mesa's off-screen OpenGL, the texgen/rasterizer/shader oracle (Debian: libosmesa6), glslang,
# which compiles the GLSL and HLSL shader snippets (Debian: glslang-tools), and Chromium, the
# real browser the viewer's tests drive through Playwright (Debian: chromium; Playwright is
# pointed at it, never downloads one).
need=()
ldconfig -p 2>/dev/null | grep -q libOSMesa || need+=(libosmesa6)
command -v glslangValidator >/dev/null || need+=(glslang-tools)
[ -x "${SPHEREMAP_CHROMIUM:-/usr/bin/chromium}" ] || need+=(chromium)
# libclang (Debian: libclang-dev), which Basis Universal's bindings are generated with: the
# UASTC HDR / ASTC HDR encoder (feature `basisu`) is built and tested where it is present.
ls /usr/lib/llvm-*/lib/libclang.so* >/dev/null 2>&1 || need+=(libclang-dev)
if [ ${#need[@]} -gt 0 ]; then
  if command -v apt-get >/dev/null && [ "$(id -u)" = 0 ]; then
    echo "== installing ${need[*]}"
    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${need[@]}" >/dev/null
  else
    echo "!! missing ${need[*]} and cannot apt-get install: the Mesa, shader-compiler or browser tests will be skipped" >&2
  fi
fi

echo "== Python test dependencies"
python3 -m pip install -q --disable-pip-version-check "numpy>=1.24" "pytest>=7" "hypothesis>=6" "PyOpenGL>=3.1.7" "maturin>=1.7,<2" ziglang auditwheel "pillow>=9" skylibs py360convert "mypy>=1.10" "playwright>=1.40" "dask[distributed]>=2024.1" blake3

# Blender's Python module (bpy, CPython 3.11 wheels only), in an environment of its own, for the
# MatCaps' check against Cycles (tests/test_lighting.py).
if [ -z "${SPHEREMAP_BPY_PYTHON:-}" ] && python3 -c 'import sys; sys.exit(sys.version_info[:2] != (3, 11))'; then
  bpy_venv="$PWD/target/bpy-venv"
  if ! "$bpy_venv/bin/python" -c "import bpy" 2>/dev/null; then
    echo "== Blender's Python module (bpy) for the Cycles reference"
    rm -rf "$bpy_venv"
    python3 -m venv "$bpy_venv"
    "$bpy_venv/bin/python" -m pip install -q --disable-pip-version-check "bpy==5.0.1"
  fi
  export SPHEREMAP_BPY_PYTHON="$bpy_venv/bin/python"
fi

features=()
wheel_features=()
if ls /usr/lib/llvm-*/lib/libclang.so* >/dev/null 2>&1 || [ -n "${LIBCLANG_PATH:-}" ]; then
  features=(--features spheremap/basisu)
  wheel_features=(--features basisu)
elif [ "${SPHEREMAP_REQUIRE_BASISU:-}" = 1 ]; then
  echo "libclang is required (SPHEREMAP_REQUIRE_BASISU=1) for the Basis Universal encoder" >&2
  exit 1
else
  echo "!! no libclang: the UASTC HDR / ASTC HDR encoder is not built; its tests are skipped" >&2
fi

echo "== cargo test"
cargo test --workspace --exclude spheremap-py -q "${features[@]}"
echo "== the core without its optional parts (the ray tracer, the photo routes)"
cargo check -q -p spheremap --lib --no-default-features
echo "== the conversion, cosine-integral and GGX-sum tests again on the portable code (as CPUs without AVX2 run it)"
SPHEREMAP_PORTABLE=1 cargo test -p spheremap -q "${features[@]}" --test resample
SPHEREMAP_PORTABLE=1 cargo test -p spheremap -q "${features[@]}" --lib -- lighting::cosine lighting::envtree
if grep -qw avx512f /proc/cpuinfo 2>/dev/null; then
  echo "== and on the AVX2 code (as CPUs without AVX-512 run it)"
  SPHEREMAP_NO_AVX512=1 cargo test -p spheremap -q "${features[@]}" --test resample
  SPHEREMAP_NO_AVX512=1 cargo test -p spheremap -q "${features[@]}" --lib -- lighting::cosine lighting::envtree
fi

echo "== building the manylinux wheel (abi3: CPython >= 3.11; glibc >= 2.28) and the sdist"
# Zig (PyPI's ziglang) links the extension against glibc 2.28's symbols and its own static C++
# library, whatever glibc this machine has, so the wheel installs on any Linux with glibc >= 2.28;
# auditwheel confirms the tag from the symbols the library actually uses.
wheels="$PWD/target/wheels"
rm -rf "$wheels"
CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$PWD/target/py}" \
  python3 -m maturin build -q --release --zig --compatibility manylinux_2_28 "${wheel_features[@]}" -o "$wheels"
python3 -m maturin sdist -o "$wheels" >/dev/null
wheel=$(ls "$wheels"/spheremap-*-manylinux_2_28_*.whl)
sdist=$(ls "$wheels"/spheremap-*.tar.gz)
audit=$(python3 -m auditwheel show "$wheel" | tr -s ' \n' ' ')
case "$audit" in
  *'platform tag: "manylinux_2_28_'*) echo "auditwheel: $(basename "$wheel") is manylinux_2_28" ;;
  *) echo "auditwheel does not confirm manylinux_2_28: $audit" >&2; exit 1 ;;
esac
python3 scripts/check_sdist.py "$sdist"
python3 -m pip install -q --disable-pip-version-check --force-reinstall --no-deps "$wheel"

echo "== the wheel in a clean virtual environment: import, CLI and demo, no Rust involved"
venv="$PWD/target/wheel-venv"
rm -rf "$venv"
python3 -m venv "$venv"
"$venv/bin/python" -m pip install -q --disable-pip-version-check "$wheel"
(
  cd "$venv"
  bin/python -c "import spheremap, numpy; m = spheremap.convert(numpy.ones((8, 16, 3), numpy.float32), 'latlong', 'sphere', size=8); assert m.shape == (8, 8, 3)"
  bin/spheremap --version
  bin/spheremap demo demo-out --size 64 >/dev/null
  test -s demo-out/teapot_contact_sheet.png
)

echo "== pytest"
python3 -m pytest -q -p no:cacheprovider tests
