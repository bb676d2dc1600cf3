"""``python -m keypose ARGS`` runs the command line, as the ``keypose`` script does."""

from ._cli import main

if __name__ == "__main__":
    main()
