"""The ``keypose`` console script: keypose's command line, compiled into the native module, run
with this process's arguments (the same verbs, options, output and exit codes as the binary)."""

import sys

from ._keypose import cli_main


def main() -> None:
    """Runs ``keypose`` with ``sys.argv`` and exits with its exit code."""
    argv = ["keypose", *sys.argv[1:]]
    sys.exit(cli_main(argv))
