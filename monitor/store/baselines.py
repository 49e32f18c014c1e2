"""A fleet's baselines in the store: one per engine, calibrated on one of the fleet's recordings of
that engine, replaced whole."""

from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime
from typing import Any

import sqlalchemy as sa

from monitor.errors import StoreError
from monitor.store.base import StoreBase
from monitor.store.schema import baselines as baseline_rows
from monitor.store.schema import recordings
from monitor.store.sql import insert_new, now, utc

__all__ = ["BaselineRow", "BaselineStore"]


@dataclass(frozen=True)
class BaselineRow:
    """A fleet's baseline of an engine: the calibration document (``engine-monitor calibrate``'s JSON),
    the stored recording it was calibrated on, the analysis version that calibrated it, and when."""

    engine_id: str
    recording_id: int
    analysis_version: str
    document: dict[str, Any]
    created_at: datetime


class BaselineStore(StoreBase):
    """The baselines of a :class:`monitor.store.Store`."""

    def put_baseline(
        self,
        fleet_id: int,
        engine_id: str,
        recording_id: int,
        analysis_version: str,
        document: dict[str, Any],
    ) -> BaselineRow:
        """Store a fleet's baseline of an engine, replacing the one it had, in one transaction.

        Parameters
        ----------
        fleet_id : int
        engine_id : str
        recording_id : int
            The fleet's stored recording of that engine it was calibrated on.
        analysis_version : str
            The version of the analysis that calibrated it.
        document : dict
            The baseline (:meth:`monitor.diagnosis.Baseline.to_document`).

        Raises
        ------
        StoreError
            If the recording is not the fleet's, or is of another engine (nothing is stored).
        """
        moment = now()
        with self.transaction() as c:
            found = c.execute(
                sa.select(recordings.c.engine_id).where(
                    (recordings.c.id == recording_id) & (recordings.c.fleet_id == fleet_id)
                )
            ).first()
            if found is None or found.engine_id != engine_id:
                raise StoreError(
                    f"recording {recording_id}: expected a recording of engine {engine_id!r} of the same "
                    f"fleet, found {'none' if found is None else 'one of engine ' + repr(found.engine_id)}"
                )
            values = {
                "recording_id": recording_id,
                "analysis_version": analysis_version,
                "document": document,
                "created_at": moment,
            }
            created = insert_new(
                c,
                baseline_rows,
                {"fleet_id": fleet_id, "engine_id": engine_id, **values},
                ["fleet_id", "engine_id"],
            )
            if not created:
                c.execute(
                    sa.update(baseline_rows)
                    .where((baseline_rows.c.fleet_id == fleet_id) & (baseline_rows.c.engine_id == engine_id))
                    .values(**values)
                )
        return BaselineRow(engine_id, recording_id, analysis_version, document, moment)

    def baseline(self, fleet_id: int, engine_id: str) -> BaselineRow | None:
        """A fleet's baseline of an engine, or None (another fleet's answers None, as none at all).

        Parameters
        ----------
        fleet_id : int
        engine_id : str
        """
        with self.db.connect() as c:
            row = c.execute(
                sa.select(baseline_rows).where(
                    (baseline_rows.c.fleet_id == fleet_id) & (baseline_rows.c.engine_id == engine_id)
                )
            ).first()
        if row is None:
            return None
        return BaselineRow(
            row.engine_id,
            int(row.recording_id),
            row.analysis_version,
            dict(row.document),
            utc(row.created_at),
        )
