"""The ``spheremap`` console script: runs the one CLI definition, compiled in Rust."""

import sys

from ._spheremap import _cli_main


def main() -> None:
    sys.exit(_cli_main(["spheremap", *sys.argv[1:]]))


if __name__ == "__main__":
    main()
