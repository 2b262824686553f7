import os
import sys

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
