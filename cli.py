"""Thin shim so `python cli.py ...` works in a checkout; the logic lives in fabhal.cli."""

from fabhal.cli import main

if __name__ == "__main__":
    raise SystemExit(main())
