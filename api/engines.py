"""The engines a fleet's recordings may name: the fleet's own descriptions, then the bundled ones.

A fleet's own description of an id takes precedence over the bundled engine of
the same id, as in the analysis (:func:`monitor.jobs.analyse.diagnose_file` is given
the fleet's description when there is one, else reads the bundled file). The
bundled descriptions are the TOML files shipped in the package
(:func:`monitor.model.engine.bundled_engines`), answered as their content in JSON,
the form in which a fleet sends its own.
"""

from __future__ import annotations

import tomllib
from functools import lru_cache
from typing import Any, Literal

from monitor.model.engine import bundled_engines
from monitor.store import Store

__all__ = ["Source", "bundled_description", "visible_engine"]

Source = Literal["fleet", "bundled"]


@lru_cache(maxsize=64)
def _bundled_text(engine_id: str) -> str | None:
    path = bundled_engines().get(engine_id)
    return None if path is None else path.read_text(encoding="utf-8")


def bundled_description(engine_id: str) -> dict[str, Any] | None:
    """A bundled engine's description (its TOML's content, a new dict each call), or None."""
    text = _bundled_text(engine_id)
    return None if text is None else tomllib.loads(text)


def visible_engine(store: Store, fleet_id: int, engine_id: str) -> tuple[dict[str, Any], Source] | None:
    """The description a fleet's recordings of ``engine_id`` are analysed with, and where it comes from:
    the fleet's own, else the bundled one; None when there is neither."""
    own = store.engine(fleet_id, engine_id)
    if own is not None:
        return own, "fleet"
    bundled = bundled_description(engine_id)
    return None if bundled is None else (bundled, "bundled")
