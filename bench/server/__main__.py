"""``python -m bench.server`` (see the package docstring)."""

from bench.server.cli import main

if __name__ == "__main__":
    main()
