"""Tests of the engine-monitor product."""
