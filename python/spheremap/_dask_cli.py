"""``python -m spheremap._dask_cli --spec JSON``: what ``spheremap batch --dask`` runs."""

import sys

from spheremap.batch import _main

if __name__ == "__main__":
    sys.exit(_main(sys.argv[1:]))
