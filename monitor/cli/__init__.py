"""The ``engine-monitor`` command line: one module per command group, each with its parser beside its
runner."""

from monitor.cli.main import main

__all__ = ["main"]
