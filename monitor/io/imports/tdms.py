"""Import from NI TDMS files (npTDMS, an optional extra)."""

from __future__ import annotations

from datetime import datetime
from pathlib import Path

from monitor.errors import FormatError
from monitor.io.imports.mapping import (
    ImportMapping,
    mapped_channel,
    mapped_start_time,
    optional_module,
    refuse_text_options,
)
from monitor.io.imports.rates import RATE_HINT
from monitor.io.recording import Recording

__all__ = ["import_tdms"]


def import_tdms(
    path: str | Path, mapping: ImportMapping, *, sample_rate_hz: float | None = None
) -> Recording:
    """A recording from an NI TDMS file.

    Parameters
    ----------
    path : str or Path
    mapping : ImportMapping
        Sources are ``group/channel``.
    sample_rate_hz : float, optional
        [Hz]; overrides the mapping's ``sample_rate_hz``, which overrides the file's ``wf_increment``.

    Returns
    -------
    Recording
    """
    nptdms = optional_module("nptdms")
    source = Path(path)
    refuse_text_options(mapping, source, "TDMS")
    given = sample_rate_hz or mapping.sample_rate_hz
    try:
        tdms = nptdms.TdmsFile.read(source)
    except Exception as error:  # npTDMS raises plain exceptions for files that are not TDMS
        raise FormatError(f"{source}: not a readable TDMS file: {error}") from None
    available = [f"{g.name}/{c.name}" for g in tdms.groups() for c in g.channels()]
    channels = []
    start: datetime | None = None
    for m in mapping.channels:
        if m.source not in available:
            raise FormatError(f"{source}: no channel {m.source!r}; the file has {', '.join(available)}")
        group, name = str(m.source).split("/", 1)
        ch = tdms[group][name]
        props = ch.properties
        increment = float(props.get("wf_increment", 0.0))
        if given is None and not increment > 0:
            raise FormatError(
                f"{source}: channel {m.source!r} has no wf_increment (sample interval); {RATE_HINT}"
            )
        if start is None and "wf_start_time" in props:
            start = props["wf_start_time"].astype("datetime64[us]").astype(datetime)
        channels.append(
            mapped_channel(
                m,
                ch[:],
                given or 1.0 / increment,
                float(props.get("wf_start_offset", 0.0)),
                str(props.get("unit_string", "")),
            )
        )
    return Recording(
        mapping.engine_id,
        mapped_start_time(mapping, start),
        tuple(channels),
        notes=mapping.notes,
        cycle_phase_deg=mapping.cycle_phase_deg,
    )
