"""A recording's measured order spectra as one JSON document (docs/spectrum-json.md).

One schema for every writer: ``engine-monitor spectrum --json``, the batch's
and the service's stored ``spectrum`` results (served by ``GET
/recordings/{id}/spectrum``). Each channel's uncertainty is its
``standard_error``: the standard error of the complex mean ``amplitude`` over
the blocks (their scatter over the square root of their count), as the
diagnosis document and the findings name theirs.

:func:`read_spectrum_document` reads what earlier versions wrote into this
form: the stored results (``recording`` the name, ``engine_id`` beside it,
without the recording's time and the angle reference) and the command's
document (``recording`` an object, each channel's spread as ``magnitude_std``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from monitor.errors import ModelError
from monitor.report.jsonsafe import json_ready
from monitor.signal.measure import SpectrumResult
from monitor.signal.spectrum import OrderSpectrum

__all__ = ["order_mask", "read_spectrum_document", "spectrum_document"]


def order_mask(spectrum: OrderSpectrum, orders: Sequence[float] | None = None, *, mean: bool = True) -> Any:
    """Which of a spectrum's orders a document lists.

    Parameters
    ----------
    spectrum : OrderSpectrum
    orders : sequence of float, optional
        The orders to list (``spectrum --orders``) [-]; default: every order.
    mean : bool, optional
        With every order: whether order 0 (the mean) is listed too.

    Returns
    -------
    ndarray of bool, shape (n_orders,)

    Raises
    ------
    ModelError
        If an order asked for is not on the spectrum's grid.
    """
    if orders is None:
        keep = np.ones(spectrum.orders.size, dtype=bool)
        keep[0] = mean
        return keep
    step = float(spectrum.orders[1]) if spectrum.orders.size > 1 else 1.0
    off_grid = [k for k in orders if abs(k / step - round(k / step)) > 1e-9]
    if off_grid:
        raise ModelError(f"--orders {off_grid}: not on the grid of this spectrum (steps of {step:g})")
    return np.isclose(spectrum.orders[:, None], np.asarray(orders)[None, :], atol=1e-9).any(axis=1)


def spectrum_document(
    result: SpectrumResult,
    *,
    recording: str = "",
    engine_id: str = "",
    start_time: str = "",
    truncated: bool = False,
    orders: Sequence[float] | None = None,
    mean: bool = True,
) -> dict[str, Any]:
    """The measured order spectra of a recording as a JSON-ready document (docs/spectrum-json.md).

    Parameters
    ----------
    result : SpectrumResult
        The spectra (:func:`monitor.signal.measure.spectra`, or those a diagnosis started from).
    recording : str, optional
        The recording's name.
    engine_id : str, optional
        The recording's engine.
    start_time : str, optional
        When it was recorded (ISO 8601, as the recording says).
    truncated : bool, optional
        Whether the file was cut short and read to its last whole chunk.
    orders : sequence of float, optional
        The orders listed (:func:`order_mask`) [-]; default: every order.
    mean : bool, optional
        With every order: whether order 0 is listed.

    Returns
    -------
    dict
        Non-finite numbers as None; ``speed_maps`` only when the result holds maps.
    """
    reference = result.reference
    correction = reference.pitch_correction
    channels = {}
    for name, spectrum in result.spectra.items():
        keep = order_mask(spectrum, orders, mean=mean)
        channels[name] = {
            "unit": result.units[name],
            "blocks": spectrum.blocks,
            "orders": spectrum.orders[keep],
            "amplitude": spectrum.magnitude[keep],
            "phase_deg": np.degrees(spectrum.phase[keep]),
            "standard_error": spectrum.standard_error[keep],
            "systematic": spectrum.systematic[keep] if spectrum.systematic is not None else None,
        }
    document: dict[str, Any] = {
        "recording": recording,
        "engine_id": engine_id,
        "start_time": start_time,
        "truncated": truncated,
        "angle_reference": {
            "channel": reference.source,
            "repairs": reference.repairs,
            "cycle_phase": reference.cycle_phase,
            "pitch_correction": None
            if correction is None
            else {
                "scope": correction.scope,
                "source": correction.source,
                "revolutions": correction.revolutions,
                "rms_deg": math.degrees(correction.rms),
                "largest_deg": math.degrees(correction.largest),
                "standard_error_deg": math.degrees(correction.standard_error),
            },
            "notes": list(reference.notes),
        },
        "mean_speed_rpm": result.mean_speed * 30 / math.pi,
        "cycle_revolutions": result.cycle_revolutions,
        "channels": channels,
    }
    if result.speed_maps:
        document["speed_maps"] = {
            name: {
                "unit": result.units[name],
                "speed_rpm": speed_map.speed * 30 / math.pi,
                "cycles": speed_map.cycles,
                "orders": speed_map.orders,
                "amplitude": speed_map.amplitude,
            }
            for name, speed_map in result.speed_maps.items()
        }
    return dict(json_ready(document))


def read_spectrum_document(document: dict[str, Any]) -> dict[str, Any]:
    """A spectrum document of any version in the current form (docs/spectrum-json.md, "Changes").

    A field an earlier version did not write is None (``start_time``, ``truncated``,
    ``angle_reference``; a channel's ``standard_error`` where only its ``magnitude_std``, a different
    quantity, was written, which is kept as it came).

    Parameters
    ----------
    document : dict
        A stored ``spectrum`` result, or a ``spectrum --json`` document, of this version or an earlier.

    Returns
    -------
    dict
        A new document; the one given is left as it is.
    """
    read = dict(document)
    written = read.get("recording")
    if isinstance(written, dict):  # the command's document before the schema was one
        read["recording"] = str(written.get("name", ""))
        for key in ("engine_id", "start_time", "truncated"):
            read[key] = written.get(key)
    for key in ("engine_id", "start_time", "truncated", "angle_reference"):
        read.setdefault(key, None)
    read["recording"] = read.get("recording") or ""
    read["channels"] = {
        name: {"standard_error": None, **channel} for name, channel in (read.get("channels") or {}).items()
    }
    return read
