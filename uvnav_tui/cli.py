"""Command line entry point ``uvnav``."""

from __future__ import annotations

import argparse
import sys


def main(argv: list[str] | None = None) -> int:
    """Parse the command line and run the chosen sub-command; returns the exit status."""
    parser = argparse.ArgumentParser(prog="uvnav", description="UVNAV integrated navigation")
    parser.parse_args(argv)
    print("uvnav: the console is not built yet (see the open issues).", file=sys.stderr)
    return 2


if __name__ == "__main__":
    raise SystemExit(main())
