"""A test-bench file imported by its suffix: MDF, TDMS or a text export (samples, or a logic
analyser's level changes)."""

from __future__ import annotations

from pathlib import Path

from monitor.errors import FormatError
from monitor.io.imports.levels import import_levels
from monitor.io.imports.mapping import LEVEL_CHANGES, ImportMapping
from monitor.io.imports.mdf import import_mdf, is_mdf
from monitor.io.imports.tdms import import_tdms
from monitor.io.imports.text import TEXT_SUFFIXES, import_text
from monitor.io.recording import Recording

__all__ = ["import_file"]


def import_file(
    path: str | Path, mapping: ImportMapping, *, sample_rate_hz: float | None = None
) -> Recording:
    """A recording from a test-bench file, read by its suffix: MDF, TDMS or a text export.

    ``.mf4`` and ``.mdf`` are MDF, ``.tdms`` is TDMS, ``.csv``, ``.txt`` and
    ``.tsv`` are text; ``.dat`` is MDF when it starts like one (MDF 3 files
    often end in ``.dat``), else text: a level-change capture when the mapping says
    ``layout = "level changes"`` (:func:`~monitor.io.imports.levels.import_levels`), else columns of
    samples (:func:`~monitor.io.imports.text.import_text`).

    Parameters
    ----------
    path : str or Path
    mapping : ImportMapping
    sample_rate_hz : float, optional
        [Hz]; overrides the mapping's ``sample_rate_hz`` and the file's own rate.

    Returns
    -------
    Recording

    Raises
    ------
    FormatError
        For an unknown suffix, and whatever the reader refuses.
    """
    source = Path(path)
    suffix = source.suffix.lower()
    if suffix == ".tdms":
        return import_tdms(source, mapping, sample_rate_hz=sample_rate_hz)
    if suffix in (".mf4", ".mdf") or (suffix == ".dat" and is_mdf(source)):
        return import_mdf(source, mapping, sample_rate_hz=sample_rate_hz)
    if suffix in TEXT_SUFFIXES and mapping.layout == LEVEL_CHANGES:
        return import_levels(source, mapping, sample_rate_hz=sample_rate_hz)
    if suffix in TEXT_SUFFIXES:
        return import_text(source, mapping, sample_rate_hz=sample_rate_hz)
    raise FormatError(
        f"{source}: unknown source type {suffix!r}; expected .mf4, .mdf, .dat, .tdms, .csv, .txt or .tsv"
    )
