"""``python -m monitor``: the same command line as ``engine-monitor``."""

from monitor.cli import main

if __name__ == "__main__":
    raise SystemExit(main())
