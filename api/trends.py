"""The fleet's trends as the routes read them: a fleet's engines at a glance, an engine's trend
points; each a store read of several queries, in a worker thread (:func:`blocking`), after the
fleet's older results have their trend points (:func:`monitor.store.trends.fill_trend_points`)."""

from __future__ import annotations

from collections.abc import Callable
from datetime import datetime
from typing import Any, TypeVar
from weakref import WeakKeyDictionary

from starlette.concurrency import run_in_threadpool

from monitor.diagnosis import ANALYSIS_VERSION
from monitor.store import Store
from monitor.store.trends import fill_trend_points, fleet_summary, read_trend

__all__ = ["blocking", "engine_trend", "fleet_engines"]

T = TypeVar("T")


async def blocking(function: Callable[..., T], *args: Any) -> T:
    """A store read of several queries (a trend, a summary): in a worker thread, so the loop serves others."""
    return await run_in_threadpool(function, *args)


_FILLED: WeakKeyDictionary[Store, set[int]] = WeakKeyDictionary()  # fleets whose older results are filled


def _filled(store: Store, fleet_id: int, c: Any) -> None:
    """Fill in a fleet's trend points of results stored before them, once per store and fleet in this
    process: every result stored since comes with its points (Store.complete), so a read need not look
    again (the look is a query over all the fleet's results)."""
    done = _FILLED.setdefault(store, set())
    if fleet_id not in done:
        fill_trend_points(c, fleet_id)
        done.add(fleet_id)


def fleet_engines(store: Store, fleet_id: int) -> list[Any]:
    """Each engine of the fleet with a diagnosed recording, at a glance (:func:`fleet_summary`)."""
    with store.transaction() as c:
        _filled(store, fleet_id, c)
        return fleet_summary(c, fleet_id, analysis_version=ANALYSIS_VERSION)


def engine_trend(
    store: Store, fleet_id: int, engine_id: str, quantities: list[str] | None, since: datetime | None
) -> list[Any]:
    """An engine's trend points (:func:`read_trend`), of these quantities (None: all) from ``since``."""
    with store.transaction() as c:
        _filled(store, fleet_id, c)
        return read_trend(
            c, fleet_id, engine_id, analysis_version=ANALYSIS_VERSION, quantities=quantities, since=since
        )
