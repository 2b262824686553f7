import math
import os
import subprocess
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.dirname(__file__))


@pytest.fixture(scope="session")
def mesa():
    """The Mesa oracle. Skipped when OSMesa/PyOpenGL are missing, unless SPHEREMAP_REQUIRE_MESA=1
    (CI sets it), in which case their absence fails the run."""
    import mesa_oracle

    try:
        mesa_oracle.renderer()
    except mesa_oracle.MesaUnavailable as e:
        if os.environ.get("SPHEREMAP_REQUIRE_MESA") == "1":
            pytest.fail(f"Mesa oracle required but unavailable: {e}")
        pytest.skip(str(e))
    return mesa_oracle


def cli(*args, cwd=None, env=None):
    """Runs the spheremap CLI as users run it (the installed package's console entry) and
    returns the completed process (text stdout/stderr)."""
    return subprocess.run([sys.executable, "-m", "spheremap", *map(str, args)], capture_output=True, text=True,
                          cwd=cwd, env=env)


def psnr(a, b, mask=None):
    """PSNR in dB of `a` against the reference `b` (over `mask` if given), the peak taken as the
    reference's 99.9th percentile and both clipped to [0, peak] (HDR-safe)."""
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    if mask is not None:
        a, b = a[mask], b[mask]
    peak = float(np.percentile(b, 99.9))
    mse = float(np.mean((np.clip(a, 0, peak) - np.clip(b, 0, peak)) ** 2))
    return 10 * math.log10(peak * peak / mse)
