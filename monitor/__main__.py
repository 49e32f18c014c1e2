"""``python -m monitor``: the same command line as ``engine-monitor``."""

from monitor.cli import main

raise SystemExit(main())
