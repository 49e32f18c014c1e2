"""HTML of the pages: the data as JSON in the page, the charts drawn by ``static/pages.js``.

Each page is the same skeleton: a header, the status and findings on top
(what a watch engineer must see first), then the charts and tables the data
allows. ``assets`` says where the scripts come from: ``"inline"`` puts them
in the page (a single file that opens anywhere, without network), any other
value is the URL prefix the service serves ``static/`` under.
"""

from __future__ import annotations

import html
import json
import math
from pathlib import Path
from typing import Any

__all__ = ["STATIC", "recording_page"]

STATIC = Path(__file__).parent / "static"
_UPLOT = "vendor/uplot-1.6.32"
_SCRIPTS = (f"{_UPLOT}/uPlot.iife.min.js", "pages.js")
_STYLES = (f"{_UPLOT}/uPlot.min.css", "pages.css")
STATUS_WORDS = {
    "healthy": "Healthy",
    "warning": "Warning",
    "alarm": "Alarm",
    "inconclusive": "Inconclusive",
}


def _plain(value: Any) -> Any:
    """JSON-safe: non-finite numbers become null (JSON has no NaN)."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    return value


def _data_script(data: dict[str, Any]) -> str:
    """The page's data as a JSON script element (``</`` escaped, so no text in it can close the element)."""
    text = json.dumps(_plain(data), allow_nan=False).replace("</", "<\\/")
    return f'<script type="application/json" id="page-data">{text}</script>'


def _head(title: str, assets: str) -> str:
    if assets == "inline":
        styles = "".join(f"<style>{(STATIC / s).read_text(encoding='utf-8')}</style>" for s in _STYLES)
    else:
        styles = "".join(f'<link rel="stylesheet" href="{html.escape(assets)}/{s}">' for s in _STYLES)
    return (
        '<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
        '<meta name="viewport" content="width=device-width, initial-scale=1">'
        f"<title>{html.escape(title)}</title>{styles}</head>\n"
    )


def _scripts(assets: str) -> str:
    if assets == "inline":  # a script's text cannot close its element early
        texts = [(STATIC / s).read_text(encoding="utf-8").replace("</script", "<\\/script") for s in _SCRIPTS]
        return "".join(f"<script>{text}</script>" for text in texts)
    return "".join(f'<script src="{html.escape(assets)}/{s}"></script>' for s in _SCRIPTS)


def _status(status: str) -> str:
    word, code = STATUS_WORDS.get(status, status.capitalize()), html.escape(status)
    return f'<span class="status status-{code}" data-status="{code}">{word}</span>'


def _findings(findings: list[dict[str, Any]]) -> str:
    if not findings:
        return '<p class="none" id="findings">No findings.</p>'
    items = "".join(
        f'<li class="finding severity-{html.escape(str(f.get("severity", "")))}">'
        f'<span class="severity">{html.escape(str(f.get("severity", "")))}</span> '
        f'<span class="subject">{html.escape(str(f.get("subject", "")))}</span>: '
        f"{html.escape(str(f.get('summary', '')))}"
        + (
            f' <span class="confidence">(confidence {100 * float(f["confidence"]):.0f} %)</span>'
            if isinstance(f.get("confidence"), int | float) and math.isfinite(float(f["confidence"]))
            else ""
        )
        + "</li>"
        for f in findings
    )
    return f'<ul class="findings" id="findings">{items}</ul>'


def recording_page(
    diagnosis: dict[str, Any],
    spectrum: dict[str, Any] | None = None,
    *,
    assets: str = "inline",
    navigation: str = "",
) -> str:
    """The recording view: status and findings on top, then the measured against the predicted orders.

    Parameters
    ----------
    diagnosis : dict
        A diagnosis document (``compare --json``).
    spectrum : dict, optional
        The recording's measured order spectra (the batch's and the service's ``spectrum`` result).
    assets : str, optional
        ``"inline"`` (a self-contained page) or the URL prefix of the served ``static/`` folder.
    navigation : str, optional
        HTML put above the header (the service's links back to the fleet and the engine).

    Returns
    -------
    str
        The page.
    """
    recording = str(diagnosis.get("recording", ""))
    engine = str(diagnosis.get("engine_id", ""))
    status = str(diagnosis.get("status", "inconclusive"))
    title = f"{recording} ({engine}): {STATUS_WORDS.get(status, status)}"
    facts = []
    for label, key, unit, digits in (("speed", "speed_rpm", "rpm", 1), ("load", "load", "", 2)):
        value = diagnosis.get(key)
        if isinstance(value, int | float) and math.isfinite(float(value)):
            facts.append(f"{label} {float(value):.{digits}f}{(' ' + unit) if unit else ''}")
    if diagnosis.get("baseline"):
        facts.append(f"baseline {html.escape(str(diagnosis['baseline']))}")
    facts.append(f"analysis version {html.escape(str(diagnosis.get('analysis_version', '')))}")
    notes = diagnosis.get("notes") or []
    notes_html = (
        '<details class="notes"><summary>Notes ({})</summary><ul>{}</ul></details>'.format(
            len(notes), "".join(f"<li>{html.escape(str(n))}</li>" for n in notes)
        )
        if notes
        else ""
    )
    data = {"view": "recording", "diagnosis": diagnosis, "spectrum": spectrum}
    return (
        _head(title, assets)
        + '<body class="view-recording">\n'
        + navigation
        + f'<header><h1><span id="recording-name">{html.escape(recording)}</span> '
        f'<span class="engine">{html.escape(engine)}</span></h1>'
        f'<p class="facts">{" · ".join(facts)}</p></header>\n'
        + f'<section class="verdict"><h2>Status {_status(status)}</h2>'
        + _findings(diagnosis.get("findings") or [])
        + notes_html
        + "</section>\n"
        + '<section id="charts"><noscript>The charts need JavaScript; the findings above do not.</noscript>'
        "</section>\n" + _data_script(data) + _scripts(assets) + "\n</body></html>\n"
    )
