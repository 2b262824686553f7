"""The ``spheremap`` console script: runs the one CLI definition, compiled in Rust."""

import os
import sys

from ._spheremap import _cli_main


def main() -> None:
    # `spheremap batch --dask` runs this interpreter's spheremap.batch.
    os.environ.setdefault("SPHEREMAP_PYTHON", sys.executable)
    sys.exit(_cli_main(["spheremap", *sys.argv[1:]]))


if __name__ == "__main__":
    main()
