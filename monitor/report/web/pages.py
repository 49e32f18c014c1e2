"""HTML of the pages: the data as JSON in the page, the charts drawn by ``static/pages.js``.

Each page is the same skeleton: a header, the status and findings on top
(what a watch engineer must see first), then the charts and tables the data
allows. A recording not diagnosed (queued, running, failed, set aside) says
so in words on top, with the reason its analysis gave, never "No findings.".
The engine page groups its trend quantities (:func:`trend_groups`): one chart
per group of judged quantities, the others one at a time behind a chooser,
so that its length does not grow with the number of sensors and orders.
``assets`` says where the scripts come from: ``"inline"`` puts them in the
page (a single file that opens anywhere, without network), any other value
is the URL prefix the service serves ``static/`` under.
"""

from __future__ import annotations

import html
import json
import math
import re
from pathlib import Path
from typing import Any

from monitor.report.jsonsafe import json_ready

__all__ = ["STATIC", "STATUS_WORDS", "engine_page", "fleet_page", "recording_page", "trend_groups"]

STATIC = Path(__file__).parent / "static"
_UPLOT = "vendor/uplot-1.6.32"
_SCRIPTS = (f"{_UPLOT}/uPlot.iife.min.js", "pages.js")
_STYLES = (f"{_UPLOT}/uPlot.min.css", "pages.css")
STATUS_WORDS = {  # a diagnosis' status, else (no diagnosis) its analysis' state
    "healthy": "Healthy",
    "warning": "Warning",
    "alarm": "Alarm",
    "inconclusive": "Inconclusive",
    "queued": "Queued",
    "running": "Running",
    "failed": "Failed",
    "set_aside": "Set aside",
    "none": "Not analysed",
}


def _data_script(data: dict[str, Any]) -> str:
    """The page's data as a JSON script element (``</`` escaped, so no text in it can close the element)."""
    text = json.dumps(json_ready(data), allow_nan=False).replace("</", "<\\/")
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


def _plural(count: int, word: str) -> str:
    return f"{count} {word}{'' if count == 1 else 's'}"


def _analysis_state(analysis: dict[str, Any]) -> str:
    """Why a recording has no diagnosis, in words: its analysis' state and the reason it last failed."""
    state = str(analysis.get("state", "none"))
    attempts = int(analysis.get("attempts") or 0)
    error = str(analysis.get("error") or "")
    retry = analysis.get("retry_after")
    again = f", not before {_when(retry)} UTC" if retry else ""
    if state == "set_aside":
        said = (
            f"Not diagnosed, and not to be tried again: its analysis was set aside after "
            f"{_plural(attempts, 'attempt')}."
        )
    elif state == "failed":
        said = (
            f"Not diagnosed yet: its analysis failed ({_plural(attempts, 'attempt')}) and will be tried "
            f"again{again}."
        )
    elif state == "running":
        said = f"Not diagnosed yet: being analysed (attempt {attempts}). Reload the page for its findings."
    elif state == "queued" and attempts:
        said = (
            f"Not diagnosed yet: queued again after {_plural(attempts, 'failed attempt')}{again}. "
            "Reload the page for its findings."
        )
    elif state == "queued":
        said = "Not diagnosed yet: queued for analysis. Reload the page for its findings."
    else:
        said = "Not diagnosed: no analysis of it is queued."
    reason = (
        f'<p class="reason" id="state-reason"><strong>Reason:</strong> {html.escape(error)}</p>'
        if error
        else ""
    )
    return (
        f'<div class="analysis-state state-{html.escape(state)}" id="analysis-state">'
        f'<p class="said" id="state-said">{html.escape(said)}</p>{reason}</div>'
    )


def _findings(findings: list[dict[str, Any]], status: str = "") -> str:
    if not findings and status == "inconclusive":
        return (
            '<p class="none" id="findings">No verdict: the recording could not be judged, for the reasons '
            "in the notes below.</p>"
        )
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


def _bearings_not_judged(diagnosis: dict[str, Any]) -> str:
    """A line saying that the main bearings were not judged, and why; "" when they were (or unsaid)."""
    bearings = diagnosis.get("main_bearings")
    if not isinstance(bearings, dict) or bearings.get("judged", True):
        return ""
    reason = str(bearings.get("not_judged_because") or "no sensor on a main bearing")
    return (
        '<p class="not-judged" id="bearings-not-judged"><strong>Main bearings not judged:</strong> '
        f"{html.escape(reason)}</p>"
    )


def recording_page(
    diagnosis: dict[str, Any],
    spectrum: dict[str, Any] | None = None,
    *,
    assets: str = "inline",
    navigation: str = "",
    analysis: dict[str, Any] | None = None,
) -> str:
    """The recording view: status and findings on top, then the measured against the predicted orders.

    Parameters
    ----------
    diagnosis : dict
        A diagnosis document (``compare --json``); without ``analysis``, or only ``recording`` and
        ``engine_id`` with it.
    spectrum : dict, optional
        The recording's measured order spectra (the batch's and the service's ``spectrum`` result).
    assets : str, optional
        ``"inline"`` (a self-contained page) or the URL prefix of the served ``static/`` folder.
    navigation : str, optional
        HTML put above the header (the service's links back to the fleet and the engine).
    analysis : dict, optional
        For a recording without a diagnosis, its analysis: ``state`` (``queued``, ``running``,
        ``failed``, ``set_aside`` or ``none``), ``attempts``, ``error`` (the reason it last failed) and
        ``retry_after`` (the time before which it is not tried again, or None). The page then says
        that state and that reason on top, in place of the findings.

    Returns
    -------
    str
        The page.
    """
    recording = str(diagnosis.get("recording", ""))
    engine = str(diagnosis.get("engine_id", ""))
    status = str(analysis.get("state", "none") if analysis else diagnosis.get("status", "inconclusive"))
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
        '<details class="notes"{}><summary>Notes ({})</summary><ul>{}</ul></details>'.format(
            " open" if status == "inconclusive" else "",  # the notes say why there is no verdict
            len(notes),
            "".join(f"<li>{html.escape(str(n))}</li>" for n in notes),
        )
        if notes
        else ""
    )
    verdict = _analysis_state(analysis) if analysis else _findings(diagnosis.get("findings") or [], status)
    verdict += _bearings_not_judged(diagnosis)
    data = {"view": "recording", "diagnosis": None if analysis else diagnosis, "spectrum": spectrum}
    return (
        _head(title, assets)
        + '<body class="view-recording">\n'
        + navigation
        + f'<header><h1><span id="recording-name">{html.escape(recording)}</span> '
        f'<span class="engine">{html.escape(engine)}</span></h1>'
        f'<p class="facts">{" · ".join(facts)}</p></header>\n'
        + f'<section class="verdict"><h2>Status {_status(status)}</h2>'
        + verdict
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


# a quantity's name (docs/trends.md) -> its group's key and title ({0}: the sensor), in page order
_GROUPS = (
    (r"cylinder \d+ strength", "strength", "Cylinder strengths"),
    (r"(.+) order deviation", "deviation", "Largest order deviation of each bearing sensor"),
    (r"(.+) impact", "impact", "Largest impact score of each sensor"),
    (r"(.+) rms velocity", "rms velocity", "Vibration severity (rms velocity)"),
    (r"speed", "speed", "Speed"),
    (r"load", "load", "Load"),
    (r"(.+) order \S+ deviation", "orders {0}", "{0}: each order's deviation"),
)


def trend_groups(quantities: dict[str, Any]) -> list[dict[str, Any]]:
    """The engine page's charts: the trend's quantities grouped by kind, one chart a group.

    The cylinders' strengths are one group, each sensor's largest order deviation another, and so are
    the impacts, the rms velocities, the speed, the load, and each sensor's deviations order by order;
    a quantity of another name is a group of its own.

    Parameters
    ----------
    quantities : dict
        The ``quantities`` of a trend document (:func:`monitor.store.trends.trend_document`): by name,
        each with its ``unit``, ``judged`` and ``drift``.

    Returns
    -------
    list of dict
        Each group's ``key``, ``title`` (with the unit), ``unit``, ``quantities`` (names, in the
        document's order), ``drifting`` (those of them with a drift found) and ``shown``: true for a
        group with a judged or drifting quantity, drawn on the page; the others are drawn one at a time,
        as chosen. Shown groups first, those with drift before the others, then in the order above.
    """
    groups: dict[tuple[str, str], dict[str, Any]] = {}
    rank: dict[tuple[str, str], int] = {}
    for name, quantity in quantities.items():
        unit = str(quantity.get("unit", ""))
        position, key, title = len(_GROUPS), name, name  # a name of no known kind: a group of its own
        for place, (pattern, kind, words) in enumerate(_GROUPS):
            match = re.fullmatch(pattern, name)
            if match:
                sensor = match.group(1) if match.groups() else ""
                position, key, title = place, kind.format(sensor), words.format(sensor)
                break
        group = groups.setdefault((key, unit), {"key": key, "title": f"{title} [{unit}]", "unit": unit})
        group.setdefault("quantities", []).append(name)
        group.setdefault("drifting", [])
        if quantity.get("drift"):
            group["drifting"].append(name)
        group["shown"] = group.get("shown", False) or bool(quantity.get("judged") or quantity.get("drift"))
        rank.setdefault((key, unit), position)
    order = sorted(groups, key=lambda k: (not groups[k]["shown"], not groups[k]["drifting"], rank[k]))
    return [groups[k] for k in order]


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
    groups = trend_groups((trend or {}).get("quantities") or {})
    findings = (latest or {}).get("findings") or []
    chooser = (
        '<section class="chooser" id="more-trends"><h2><label for="trend-choice">More quantities (not judged '
        "for drift), one group at a time</label></h2>"
        '<select id="trend-choice">'
        + "".join(
            f'<option value="{html.escape(g["key"])}">{html.escape(g["title"])}</option>'
            for g in groups
            if not g["shown"]
        )
        + '</select><div id="chart-choice"></div></section>\n'
        if any(not g["shown"] for g in groups)
        else ""
    )
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
    data = {"view": "engine", "trend": trend, "latest": latest, "groups": groups}
    return (
        _head(f"{engine_id}: {STATUS_WORDS.get(status, status)}", assets)
        + '<body class="view-engine">\n'
        + f'<nav><a href="{html.escape(links.fleet)}">Fleet</a></nav>'
        + f"<header><h1>{html.escape(engine_id)}</h1></header>\n"
        + f'<section class="verdict"><h2>Latest recording {_status(status)}{latest_link}</h2>'
        + _findings(findings, status)
        + _bearings_not_judged(latest or {})
        + f"<h2>Trend findings</h2>{trend_html}</section>\n"
        + '<section id="charts"><noscript>The charts need JavaScript; the findings above do not.</noscript>'
        "</section>\n" + chooser + _data_script(data) + _scripts(assets) + "\n</body></html>\n"
    )
