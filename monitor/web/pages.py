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

__all__ = ["STATIC", "engine_page", "fleet_page", "recording_page"]

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


def _when(value: Any) -> str:
    """A time as the pages show it (UTC, to the minute)."""
    return value.strftime("%Y-%m-%d %H:%M") if hasattr(value, "strftime") else html.escape(str(value))[:16]


def fleet_page(fleet: str, engines: list[Any], *, links: Any, assets: str) -> str:
    """The fleet view: each engine's latest verdict at a glance, coloured, worst first.

    Parameters
    ----------
    fleet : str
        The fleet's name.
    engines : list of EngineSummary
        :func:`monitor.store.trends.fleet_summary`.
    links : object
        ``engine(engine_id)`` and ``recording(recording_id)``: the URLs of those views; ``logout``: the
        URL that ends the session.
    assets : str
        The URL prefix of the served ``static/`` folder.

    Returns
    -------
    str
    """
    rank = {"alarm": 0, "warning": 1, "inconclusive": 2, "healthy": 3}
    ordered = sorted(engines, key=lambda e: (rank.get(e.latest_status, 2), e.engine_id))
    rows = "".join(
        f'<tr class="engine-row" data-engine="{html.escape(e.engine_id)}" '
        f'data-status="{html.escape(e.latest_status)}">'
        f'<td><a href="{html.escape(links.engine(e.engine_id))}">{html.escape(e.engine_id)}</a></td>'
        f"<td>{_status(e.latest_status)}</td>"
        f'<td><a href="{html.escape(links.recording(e.latest_recording_id))}">'
        f"{html.escape(e.latest_filename)}</a> ({_when(e.latest_recorded_at)} UTC)</td>"
        f"<td>{e.recordings}</td><td>{e.alarms}</td><td>{e.warnings}</td></tr>"
        for e in ordered
    )
    table = (
        '<table class="fleet" id="fleet"><tr><th>engine</th><th>latest status</th><th>latest recording</th>'
        f"<th>diagnosed</th><th>alarms</th><th>warnings</th></tr>{rows}</table>"
        if engines
        else '<p class="none" id="fleet">No diagnosed recording yet: upload one, or run the nightly batch.'
        "</p>"
    )
    worst = ordered[0].latest_status if ordered else "none"
    return (
        _head(f"Fleet {fleet}", assets)
        + '<body class="view-fleet">\n'
        + f'<nav><form method="post" action="{html.escape(links.logout)}" class="logout">'
        '<button type="submit" id="logout">Log out</button></form></nav>'
        + f"<header><h1>Fleet {html.escape(fleet)}</h1>"
        f'<p class="facts">{len(engines)} engine(s) · worst latest status {_status(worst)}</p></header>\n'
        + f"<section>{table}</section>\n"
        + "</body></html>\n"
    )


def engine_page(
    engine_id: str,
    trend: dict[str, Any] | None,
    latest: dict[str, Any] | None,
    *,
    latest_id: int | None,
    links: Any,
    assets: str,
) -> str:
    """The engine view: the latest verdict and findings, the trend findings, then the charts.

    Parameters
    ----------
    engine_id : str
    trend : dict or None
        :func:`monitor.store.trends.trend_document`.
    latest : dict or None
        The latest recording's diagnosis document.
    latest_id : int or None
        Its recording id.
    links : object
        ``fleet``, ``recording(recording_id)``.
    assets : str
        The URL prefix of the served ``static/`` folder.

    Returns
    -------
    str
    """
    status = str((latest or {}).get("status", "none"))
    findings = (latest or {}).get("findings") or []
    drift = (trend or {}).get("findings") or []
    trend_html = (
        '<ul class="findings" id="trend-findings">'
        + "".join(f'<li class="finding severity-warning">{html.escape(str(d))}</li>' for d in drift)
        + "</ul>"
        if drift
        else '<p class="none" id="trend-findings">No trend finding: every judged quantity within its '
        "history.</p>"
    )
    name = html.escape(str((latest or {}).get("recording", "")))
    latest_link = (
        f' <a href="{html.escape(links.recording(latest_id))}">{name}</a>' if latest_id is not None else ""
    )
    data = {"view": "engine", "trend": trend, "latest": latest}
    return (
        _head(f"{engine_id}: {STATUS_WORDS.get(status, status)}", assets)
        + '<body class="view-engine">\n'
        + f'<nav><a href="{html.escape(links.fleet)}">Fleet</a></nav>'
        + f"<header><h1>{html.escape(engine_id)}</h1></header>\n"
        + f'<section class="verdict"><h2>Latest recording {_status(status)}{latest_link}</h2>'
        + _findings(findings)
        + f"<h2>Trend findings</h2>{trend_html}</section>\n"
        + '<section id="charts"><noscript>The charts need JavaScript; the findings above do not.</noscript>'
        "</section>\n" + _data_script(data) + _scripts(assets) + "\n</body></html>\n"
    )
