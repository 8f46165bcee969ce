"""The ``detnoise`` command installed with the package: the same command line as the binary."""

import sys

from ._detnoise import run_cli


def main() -> None:
    """Run ``detnoise`` with this process's arguments and exit with its status."""
    sys.exit(run_cli(["detnoise", *sys.argv[1:]]))


if __name__ == "__main__":
    main()
