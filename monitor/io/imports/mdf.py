"""Import from ASAM MDF (3 or 4) files (asammdf, an optional extra)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from monitor.errors import FormatError
from monitor.io.imports.mapping import (
    ImportMapping,
    mapped_channel,
    mapped_start_time,
    optional_module,
    refuse_text_options,
)
from monitor.io.imports.rates import Rounding, fixed_rate, grid_rounding
from monitor.io.recording import Recording

__all__ = ["import_mdf", "is_mdf"]


def import_mdf(path: str | Path, mapping: ImportMapping, *, sample_rate_hz: float | None = None) -> Recording:
    """A recording from an ASAM MDF (3 or 4) file.

    Parameters
    ----------
    path : str or Path
    mapping : ImportMapping
        Sources are channel names.
    sample_rate_hz : float, optional
        [Hz]; overrides the mapping's ``sample_rate_hz``. Without either, each
        channel's rate is derived from its time stamps, within their rounding.

    Returns
    -------
    Recording

    Raises
    ------
    FormatError
        For a missing channel or one not sampled at a fixed rate.
    """
    asammdf = optional_module("asammdf")
    source = Path(path)
    refuse_text_options(mapping, source, "MDF")
    given = sample_rate_hz or mapping.sample_rate_hz
    try:
        mdf = asammdf.MDF(source)
    except Exception as error:  # asammdf raises plain exceptions for files that are not MDF
        raise FormatError(f"{source}: not a readable MDF file: {error}") from None
    with mdf:
        available = sorted(mdf.channels_db)
        channels = []
        for m in mapping.channels:
            if m.source not in mdf.channels_db:
                raise FormatError(f"{source}: no channel {m.source!r}; the file has {', '.join(available)}")
            signal = mdf.get(m.source)
            stamps = np.asarray(signal.timestamps, dtype=np.float64)
            if stamps.size == 0:
                raise FormatError(f"{source}: channel {m.source!r} has no samples")
            if given is not None:
                rate = given
            else:
                rounding = (
                    Rounding(stated=mapping.time_tolerance_s)
                    if mapping.time_tolerance_s is not None
                    else grid_rounding(stamps)
                )
                rate = fixed_rate(
                    stamps, rounding, f"{source}: channel {m.source!r}", lambda k: f"sample {k}"
                )
            channels.append(
                mapped_channel(m, np.asarray(signal.samples), rate, float(stamps[0]), str(signal.unit or ""))
            )
        start = mdf.header.start_time
    return Recording(
        mapping.engine_id,
        mapped_start_time(mapping, start),
        tuple(channels),
        notes=mapping.notes,
        cycle_phase_deg=mapping.cycle_phase_deg,
    )


def is_mdf(source: Path) -> bool:
    """Whether the file starts as an MDF file does (MDF 3 files often end in ``.dat``).

    Parameters
    ----------
    source : Path
        The file; one that cannot be read is not an MDF file.

    Returns
    -------
    bool
        True if its first bytes are ``MDF`` or ``UnFinMF`` (an MDF 4 file not finalised).
    """
    try:
        with open(source, "rb") as fh:
            return fh.read(8).startswith((b"MDF", b"UnFinMF"))
    except OSError:
        return False
