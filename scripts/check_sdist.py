"""Checks the source distribution: every file the build reads is in it, and cargo resolves its
workspace from the archive alone (the lock file, the member crates) without the network.

Usage: python3 scripts/check_sdist.py spheremap-X.tar.gz   (from the repository root)
"""

import os
import subprocess
import sys
import tarfile
import tempfile
from pathlib import Path

# What a build from the sdist reads: the crates (sources, build script, embedded data, the
# viewer's page), the Python package, and the metadata files.
NEEDED = ["Cargo.toml", "Cargo.lock", "pyproject.toml", "README.md", "LICENSE-MIT", "LICENSE-APACHE"]
TREES = ["python/spheremap"] + [
    f"crates/{c}/{part}"
    for c in ("spheremap", "spheremap-cli", "spheremap-py", "spheremap-view")
    for part in ("Cargo.toml", "build.rs", "src", "data", "web")
]


def wanted(root: Path) -> set[str]:
    out = set(NEEDED)
    for t in TREES:
        p = root / t
        if p.is_file():
            out.add(t)
        elif p.is_dir():
            for f in p.rglob("*"):
                if f.is_file() and "__pycache__" not in f.parts:
                    out.add(f.relative_to(root).as_posix())
    return out


def main() -> int:
    sdist = Path(sys.argv[1])
    root = Path.cwd()
    with tarfile.open(sdist) as tar, tempfile.TemporaryDirectory() as tmp:
        names = tar.getnames()
        top = names[0].split("/")[0]
        have = {n.split("/", 1)[1] for n in names if "/" in n}
        missing = sorted(wanted(root) - have)
        if missing:
            print(f"{sdist.name}: {len(missing)} files missing, e.g. {missing[:5]}", file=sys.stderr)
            return 1
        tar.extractall(tmp, filter="data")
        r = subprocess.run(
            ["cargo", "metadata", "--offline", "--locked", "--format-version", "1",
             "--manifest-path", os.path.join(tmp, top, "Cargo.toml")],
            capture_output=True, text=True,
        )
        if r.returncode != 0:
            print(f"{sdist.name}: cargo cannot resolve its workspace: {r.stderr.strip()}", file=sys.stderr)
            return 1
    print(f"{sdist.name}: {len(have)} files, every source the build reads, a workspace cargo resolves offline")
    return 0


if __name__ == "__main__":
    sys.exit(main())
