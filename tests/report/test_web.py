"""The web pages in a real headless Chromium: what a watch engineer sees first, charts that zoom and hover."""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from monitor.diagnosis import calibrate, diagnose
from monitor.io.hdf5 import read_hdf5, write_hdf5
from monitor.model.engine import bundled_engines, load_engine
from monitor.report.diagnosis import diagnosis_document
from monitor.report.web import recording_page
from monitor.store.schema import JOB_STATES

ROOT = Path(__file__).resolve().parents[2]
SAMPLES = ROOT / "recordings" / "samples"


@pytest.fixture(scope="module")
def alarm_document() -> dict[str, Any]:
    """The bundled misfire recording diagnosed against a baseline calibrated on the healthy one."""
    engine = load_engine(bundled_engines()["man-b-w-7k98mc"])
    baseline = calibrate(read_hdf5(SAMPLES / "7k98mc-baseline.h5"), engine, source="7k98mc-baseline.h5")
    diagnosis = diagnose(read_hdf5(SAMPLES / "7k98mc-misfire-cyl4.h5"), engine, baseline=baseline)
    return diagnosis_document(diagnosis, recording="7k98mc-misfire-cyl4.h5")


def _rgba(text: str) -> tuple[float, ...]:
    """A computed CSS colour (``rgb(r, g, b)`` or ``rgba(r, g, b, a)``): red, green, blue [0, 255], alpha."""
    numbers = [float(n) for n in re.findall(r"[-+]?\d*\.?\d+", text)]
    assert text.startswith("rgb") and len(numbers) in (3, 4), f"not a colour the test reads: {text!r}"
    return (*numbers[:3], numbers[3] if len(numbers) == 4 else 1.0)


def _contrast(first: tuple[float, ...], second: tuple[float, ...]) -> float:
    """WCAG 2.x contrast ratio of two opaque colours, (L1 + 0.05) / (L2 + 0.05), L each one's relative
    luminance (the sRGB channels linearised, weighted 0.2126, 0.7152, 0.0722)."""

    def luminance(colour: tuple[float, ...]) -> float:
        c = [v / 255 for v in colour[:3]]
        linear = [v / 12.92 if v <= 0.04045 else ((v + 0.055) / 1.055) ** 2.4 for v in c]
        return 0.2126 * linear[0] + 0.7152 * linear[1] + 0.0722 * linear[2]

    light, dark = sorted((luminance(first), luminance(second)), reverse=True)
    return (light + 0.05) / (dark + 0.05)


def _assert_legible(browser: Any, badge: Any) -> None:
    """A badge of its own colour, opaque, its text at a contrast of at least 4.5:1 against it (WCAG AA for
    text of its size)."""
    text, background = browser.execute_script(
        "var s = getComputedStyle(arguments[0]); return [s.color, s.backgroundColor];", badge
    )
    fore, back = _rgba(text), _rgba(background)
    assert back[3] == 1.0 and fore[3] == 1.0, f"{badge.text!r}: text {text} on {background}"
    assert _contrast(fore, back) >= 4.5, f"{badge.text!r}: text {text} on {background}"


def test_a_self_contained_page_refers_to_nothing_outside_it(alarm_document: dict[str, Any]) -> None:
    """For a ship without network: every script and style inline, no URL to fetch; data that could close
    the data element (a note with </script> in it) cannot."""
    document = dict(alarm_document, notes=["a note with </script><b>markup</b> in it"])
    page = recording_page(document)
    assert not re.search(r"""(src|href)\s*=\s*["']?(https?:)?//""", page)
    assert page.count("<script") == page.count("</script>") == 3  # the data, uPlot, the page's script
    assert "</script><b>" not in page


def test_the_recording_view_shows_status_and_findings_first_and_its_charts_zoom_and_hover(
    browser: Any, alarm_document: dict[str, Any], tmp_path: Path
) -> None:
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By

    path = tmp_path / "recording.html"
    path.write_text(recording_page(alarm_document), encoding="utf-8")
    browser.get(path.as_uri())
    status = browser.find_element(By.CSS_SELECTOR, ".verdict .status")
    assert status.get_attribute("data-status") == "alarm" and status.text == "Alarm"
    findings = browser.find_element(By.ID, "findings").text
    assert "cylinder 4" in findings and "ALARM" in findings.upper()
    charts = browser.find_element(By.ID, "charts")
    assert status.location["y"] < charts.location["y"]  # the verdict above every chart
    # the cylinder balance and one chart per compared channel, each drawn
    expected = 1 + len(alarm_document["channels"])
    assert int(browser.find_element(By.TAG_NAME, "body").get_attribute("data-charts")) == expected
    assert len(browser.find_elements(By.CSS_SELECTOR, "#charts .uplot canvas")) == expected
    # hover: the legend shows the values under the cursor
    area = browser.find_elements(By.CSS_SELECTOR, "#chart-channel-1 .u-over")[0]
    ActionChains(browser).move_to_element_with_offset(area, 10, 5).perform()
    legend = browser.find_element(By.CSS_SELECTOR, "#chart-channel-1 .u-legend").text
    assert "--" not in legend.split("measured")[1].split("predicted")[0], legend
    # zoom: dragging across a chart narrows its order axis
    before = browser.execute_script("var u = enginePages.charts[2]; return [u.scales.x.min, u.scales.x.max];")
    ActionChains(browser).move_to_element_with_offset(area, -200, 0).click_and_hold().move_by_offset(
        150, 0
    ).release().perform()
    after = browser.execute_script("var u = enginePages.charts[2]; return [u.scales.x.min, u.scales.x.max];")
    assert after[1] - after[0] < 0.5 * (before[1] - before[0]), (before, after)
    browser.save_screenshot(str(tmp_path / "recording.png"))
    assert (tmp_path / "recording.png").stat().st_size > 20_000


STATUSES = ("healthy", "warning", "alarm", "inconclusive", *JOB_STATES, "none", "a-status-with-no-rule")


def test_every_status_badge_is_opaque_and_legible(browser: Any, tmp_path: Path) -> None:
    """Each status a page may show (a diagnosis', or an analysis' state when there is none, and one no
    style names) on a badge of its own colour with text at 4.5:1 or more: a set-aside recording's badge
    was white text on no background at all."""
    from selenium.webdriver.common.by import By

    for status in STATUSES:
        path = tmp_path / f"{status}.html"
        document = {"recording": "r.h5", "engine_id": "e", "status": status, "findings": []}
        path.write_text(recording_page(document), encoding="utf-8")
        browser.get(path.as_uri())
        badge = browser.find_element(By.CSS_SELECTOR, ".verdict .status")
        assert badge.get_attribute("data-status") == status and badge.text
        _assert_legible(browser, badge)


@pytest.mark.parametrize(
    ("state", "attempts", "error", "said"),
    [
        ("queued", 0, "", "queued for analysis"),
        ("queued", 1, "the store was unreachable", "queued again after 1 failed attempt"),
        ("running", 1, "", "being analysed"),
        ("failed", 2, "worker lost", "will be tried again"),
        ("set_aside", 3, "no usable angle reference", "set aside after 3 attempts"),
    ],
)
def test_a_recording_without_a_diagnosis_says_its_analysis_state_and_why_on_top(
    browser: Any, tmp_path: Path, state: str, attempts: int, error: str, said: str
) -> None:
    """Not "No findings." (which reads as healthy) but the analysis' state in words, and the reason it
    last failed, shown unfolded above everything else; no chart is drawn from a diagnosis that is not
    there."""
    from selenium.webdriver.common.by import By

    analysis = {"state": state, "attempts": attempts, "error": error, "retry_after": None}
    path = tmp_path / "state.html"
    path.write_text(
        recording_page({"recording": "r.h5", "engine_id": "e"}, analysis=analysis), encoding="utf-8"
    )
    browser.get(path.as_uri())
    badge = browser.find_element(By.CSS_SELECTOR, ".verdict .status")
    assert badge.get_attribute("data-status") == state
    text = browser.find_element(By.ID, "analysis-state")
    assert text.is_displayed() and said in text.text and error in text.text
    assert "No findings" not in browser.find_element(By.TAG_NAME, "body").text
    assert browser.find_element(By.TAG_NAME, "body").get_attribute("data-charts") == "0"


def test_an_inconclusive_diagnosis_shows_why_unfolded(browser: Any, tmp_path: Path) -> None:
    """No verdict and no finding: the notes that say why are open on the page, not folded under
    "No findings." (which reads as healthy)."""
    from selenium.webdriver.common.by import By

    note = "the recording is 0.4 s long: fewer than the 2 cycles the orders need"
    document = {"recording": "r.h5", "engine_id": "e", "status": "inconclusive", "notes": [note]}
    path = tmp_path / "inconclusive.html"
    path.write_text(recording_page(document), encoding="utf-8")
    browser.get(path.as_uri())
    assert "No findings" not in browser.find_element(By.TAG_NAME, "body").text
    assert browser.find_element(By.CSS_SELECTOR, ".notes li").is_displayed()


def test_every_predicted_amplitude_is_drawn_within_its_log_axis(
    browser: Any, alarm_document: dict[str, Any], tmp_path: Path
) -> None:
    """The crank-speed model predicts zero at the orders the cylinders do not fire at (some 1e-16 rad/s,
    rounding): on the logarithmic axis they fell off, and one predicted point of nine was drawn. Every
    amplitude is drawn within the axis now: as it is, or on the chart's floor when smaller (its own value
    in the legend, said to be below the floor)."""
    channel = alarm_document["channels"]["crank speed"]
    assert min(channel["predicted_amplitude"]) < 1e-9 * max(channel["predicted_amplitude"])  # the case
    path = tmp_path / "recording.html"
    path.write_text(recording_page(alarm_document), encoding="utf-8")
    browser.get(path.as_uri())
    read = """
        var box = document.getElementById(arguments[0]);
        var u = enginePages.charts.filter(function (p) { return box.contains(p.root); })[0];
        var floor = u.series.length > 3 ? u.data[3][0] : null;  // the floor's line, where there is one
        return {data: u.data, min: u.scales.y.min, max: u.scales.y.max, floor: floor};"""
    hover = """
        var box = document.getElementById(arguments[0]);
        var u = enginePages.charts.filter(function (p) { return box.contains(p.root); })[0];
        u.setCursor({left: u.valToPos(arguments[1], "x"), top: 10});
        return box.querySelector(".u-legend").textContent;"""
    for k, c in enumerate(alarm_document["channels"].values()):
        chart = browser.execute_script(read, f"chart-channel-{k}")
        amplitudes = ((2, c["predicted_amplitude"]), (1, c["measured_amplitude"]))
        for series, raw in amplitudes:  # each one drawn, within the axis
            for order, value, drawn in zip(c["orders"], raw, chart["data"][series], strict=True):
                assert drawn is not None and chart["min"] <= drawn <= chart["max"], (k, order, value, drawn)
        for series, raw in amplitudes:  # as it is, or on the floor and said to be below it
            for order, value, drawn in zip(c["orders"], raw, chart["data"][series], strict=True):
                # rel=1e-12: the number itself, or the floor, through JSON and back (exact in practice)
                if value >= chart["floor"]:
                    assert drawn == pytest.approx(value, rel=1e-12)
                else:
                    assert drawn == pytest.approx(chart["floor"], rel=1e-12)
                    legend = browser.execute_script(hover, f"chart-channel-{k}", order)
                    assert "below the floor" in legend, legend
    crank = browser.execute_script(read, "chart-channel-0")
    assert crank["floor"] < min(channel["measured_amplitude"])  # the floor under every measured amplitude


def _screenshot(browser: Any, folder: Path, name: str, *, whole: bool = False) -> Path:
    """Save the page as the test sees it (``whole``: all of its length, not the first screen): under the
    test's folder, and under $ENGINE_MONITOR_SCREENSHOTS too when set (``make screenshots`` writes the
    docs' pictures that way)."""
    import os
    import shutil

    path = folder / f"{name}.png"
    if whole:
        size = browser.get_window_size()
        bars, height = browser.execute_script(
            "return [window.outerHeight - window.innerHeight, document.documentElement.scrollHeight];"
        )
        browser.set_window_size(size["width"], height + bars)
        try:
            browser.save_screenshot(str(path))
        finally:
            browser.set_window_size(size["width"], size["height"])
    else:
        browser.save_screenshot(str(path))
    assert path.stat().st_size > 10_000
    wanted = os.environ.get("ENGINE_MONITOR_SCREENSHOTS")
    if wanted:
        Path(wanted).mkdir(parents=True, exist_ok=True)
        shutil.copy(path, Path(wanted) / path.name)
    return path


@pytest.fixture(scope="module")
def service(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[Any, dict[str, int]]]:
    """A server with two fleets. Fleet a: the 7K98MC's healthy recording, set as the engine's
    baseline; its misfire recording, analysed against that baseline (so its bearing sensors'
    orders are compared, two dozen each); a recording of it without an angle reference, which its
    analysis sets aside. Fleet b: the 6L32 misfire. The recordings' ids by file name."""
    from dataclasses import replace

    from tests.api.test_api import _upload, _wait_done, two_fleet_server

    folder = tmp_path_factory.mktemp("service")
    sample = read_hdf5(SAMPLES / "7k98mc-baseline.h5")
    blind = folder / "no-angle.h5"
    write_hdf5(replace(sample, channels=tuple(c for c in sample.channels if c.kind == "acceleration")), blind)
    server = two_fleet_server(folder)
    try:
        with server.client("a") as a, server.client("b") as b:
            ids = {"6l32-misfire-cyl3.h5": int(_upload(b, SAMPLES / "6l32-misfire-cyl3.h5").json()["id"])}
            healthy = int(_upload(a, SAMPLES / "7k98mc-baseline.h5").json()["id"])
            ids["7k98mc-baseline.h5"] = healthy
            # calibrated from the stored file while its own analysis runs (which may or may not see it)
            baseline = a.post("/engines/man-b-w-7k98mc/baseline", json={"recording_id": healthy})
            assert baseline.status_code == 201, baseline.text
            for path in (SAMPLES / "7k98mc-misfire-cyl4.h5", blind):
                ids[path.name] = int(_upload(a, path).json()["id"])
            for name, recording in ids.items():
                client = b if name.startswith("6l32") else a
                expected = "set_aside" if name == blind.name else "done"
                assert _wait_done(client, recording)["status"] == expected, name
        yield server, ids
    finally:
        server.kill()


def _log_in(browser: Any, server: Any, fleet: str = "a") -> None:
    """Log the browser in to a fleet through the login form (a new session)."""
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import WebDriverWait

    browser.delete_all_cookies()
    browser.get(f"{server.url}/ui")
    assert "/login" in browser.current_url  # no session: the login first
    browser.find_element(By.ID, "key").send_keys(server.keys[fleet])
    browser.find_element(By.CSS_SELECTOR, "form button[type=submit]").click()
    # the form's answer is a redirect the browser follows after click() returns: wait for it
    WebDriverWait(browser, 30).until(lambda page: page.current_url.endswith("/ui"))


def test_the_service_pages_log_in_and_show_the_fleet_an_engine_and_a_recording(
    browser: Any, service: tuple[Any, dict[str, int]], tmp_path: Path
) -> None:
    """Recordings uploaded here, analysed by the service; a browser logs in with fleet a's key through the
    form and finds each engine's latest verdict on the fleet page (as GET /fleet says), the engine page
    with its charts and trend findings, the recording page with the alarm and its finding on top; fleet
    b's engine and recording answer 404 to it, pages and JSON alike."""
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import WebDriverWait

    server, ids = service
    theirs = ids["6l32-misfire-cyl3.h5"]
    with server.client("a") as a:
        fleet = a.get("/fleet").json()
        assert [e["engine_id"] for e in fleet["engines"]] == ["man-b-w-7k98mc"]
        assert a.get("/engines/medium-speed-6l32/trend").status_code == 404  # fleet b's only
        assert a.get(f"/ui/recordings/{theirs}").status_code == 404
        trend = a.get("/engines/man-b-w-7k98mc/trend").json()
        assert len(trend["quantities"]["cylinder 4 strength"]["points"]) == 2
    _log_in(browser, server)
    rows = browser.find_elements(By.CSS_SELECTOR, "#fleet .engine-row")
    assert [(r.get_attribute("data-engine"), r.get_attribute("data-status")) for r in rows] == [
        (e["engine_id"], e["latest"]["status"]) for e in fleet["engines"]
    ]
    _screenshot(browser, tmp_path, "fleet")
    rows[0].find_element(By.CSS_SELECTOR, "a").click()  # the engine
    WebDriverWait(browser, 30).until(lambda page: "/ui/engines/man-b-w-7k98mc" in page.current_url)
    assert browser.find_element(By.ID, "trend-findings").text
    assert int(browser.find_element(By.TAG_NAME, "body").get_attribute("data-charts")) >= 2
    browser.get(f"{server.url}/ui/recordings/{ids['7k98mc-misfire-cyl4.h5']}")
    status = browser.find_element(By.CSS_SELECTOR, ".verdict .status")
    assert status.get_attribute("data-status") == "alarm"
    assert "cylinder 4" in browser.find_element(By.ID, "findings").text
    assert status.location["y"] < browser.find_element(By.ID, "charts").location["y"]
    assert int(browser.find_element(By.TAG_NAME, "body").get_attribute("data-charts")) >= 3
    _screenshot(browser, tmp_path, "recording")
    browser.get(f"{server.url}/ui/recordings/{theirs}")
    assert "no recording" in browser.page_source
    browser.get(f"{server.url}/ui/engines/medium-speed-6l32")
    assert "no diagnosed recording" in browser.page_source


def test_the_service_says_why_a_set_aside_recording_has_no_diagnosis(
    browser: Any, service: tuple[Any, dict[str, int]], tmp_path: Path
) -> None:
    """A recording whose analysis was set aside (no angle reference) showed a badge drawn white on
    nothing, then "No findings." with the reason folded away in the notes. Its page says "Set aside" on
    a badge one can read, and why, in words, on top and unfolded."""
    from selenium.webdriver.common.by import By

    server, ids = service
    _log_in(browser, server)
    browser.get(f"{server.url}/ui/recordings/{ids['no-angle.h5']}")
    status = browser.find_element(By.CSS_SELECTOR, ".verdict .status")
    assert status.get_attribute("data-status") == "set_aside"
    _assert_legible(browser, status)
    assert "No findings" not in browser.find_element(By.TAG_NAME, "body").text
    state = browser.find_element(By.ID, "analysis-state")
    assert state.is_displayed() and "set aside" in state.text and status.text == "Set aside"
    assert "no usable angle reference" in state.text  # the analysis's own reason, as GET /recordings/{id}
    top = browser.execute_script("return arguments[0].getBoundingClientRect().bottom;", state)
    assert top < browser.execute_script("return window.innerHeight;")  # on the first screen, not scrolled to
    _screenshot(browser, tmp_path, "recording-set-aside")


ENGINE_PAGE_MAX_PX = 4000  # the 7K98MC's page was 21 600 px tall: 64 charts, one per quantity


def test_the_service_engine_page_groups_its_quantities_and_stays_short(
    browser: Any, service: tuple[Any, dict[str, int]], tmp_path: Path
) -> None:
    """The engine page drew a chart for each of the 7K98MC's 64 quantities (48 of them one bearing
    order's deviation), 21 600 px of page. Now it draws a chart per group of judged quantities and the
    rest one group at a time, as chosen: the page stays under ENGINE_PAGE_MAX_PX, and every quantity of
    the trend is on it, in a chart drawn or in one the chooser draws, each once."""
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import Select

    server, _ = service
    with server.client("a") as a:
        quantities = list(a.get("/engines/man-b-w-7k98mc/trend").json()["quantities"])
    assert len(quantities) > 40  # the many quantities the page must summarise
    _log_in(browser, server)
    browser.get(f"{server.url}/ui/engines/man-b-w-7k98mc")
    height = browser.execute_script("return document.documentElement.scrollHeight;")
    assert height < ENGINE_PAGE_MAX_PX, height
    labels = """
        var box = document.getElementById(arguments[0]);
        return enginePages.charts.filter(function (u) { return box.contains(u.root); })
            .map(function (u) { return u.series.slice(1).map(function (s) { return s.label; }); });"""
    on_page = [
        label for chart in browser.execute_script(labels, "charts")[1:] for label in chart
    ]  # not the balance
    choice = Select(browser.find_element(By.ID, "trend-choice"))
    chosen = []
    for value in [option.get_attribute("value") for option in choice.options]:
        choice.select_by_value(value)
        (series,) = browser.execute_script(labels, "chart-choice")  # the chosen group's chart, alone
        chosen.extend(series)
        assert browser.execute_script("return document.documentElement.scrollHeight;") < ENGINE_PAGE_MAX_PX
    drawn = [label.removesuffix(" (drift)") for label in on_page + chosen]
    assert sorted(drawn) == sorted(quantities)
    choice.select_by_index(0)
    _screenshot(browser, tmp_path, "engine", whole=True)


def test_the_wheel_carries_every_script_and_style_the_pages_load(tmp_path: Path) -> None:
    """No step downloads anything at build or run time: the product's wheel (built here from a copy of
    the sources, without fetching) holds every file a page refers to, the vendored chart library and
    its licence among them."""
    import shutil
    import subprocess
    import sys
    import zipfile

    from monitor.report.web import pages

    source = tmp_path / "source"
    source.mkdir()
    for name in ("pyproject.toml", "README.md"):
        shutil.copy(ROOT / name, source / name)
    for package in ("monitor", "api"):
        shutil.copytree(ROOT / package, source / package, ignore=shutil.ignore_patterns("__pycache__"))
    command = [sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "--no-index"]
    built = subprocess.run(
        [*command, "-q", "-w", str(tmp_path / "wheel"), str(source)],
        capture_output=True,
        text=True,
        check=False,
    )
    assert built.returncode == 0, built.stderr
    (wheel,) = (tmp_path / "wheel").glob("*.whl")
    names = set(zipfile.ZipFile(wheel).namelist())
    wanted = [*pages._SCRIPTS, *pages._STYLES, f"{pages._UPLOT}/LICENSE"]
    missing = [name for name in wanted if f"monitor/report/web/static/{name}" not in names]
    assert not missing, f"the wheel lacks {missing}"


def test_a_crank_speed_only_recording_shows_its_bearings_not_judged(browser: Any, tmp_path: Path) -> None:
    """A recording of a tooth wheel and a cam alone (written with h5py by the test), healthy: under the
    healthy badge and its "No findings.", a line says that the main bearings were not judged and why,
    above the charts, which draw the cylinder balance and the crank speed as for any recording."""
    from selenium.webdriver.common.by import By

    from tests.diagnosis.crank_only_files import ENGINE, write_crank_only

    recording = write_crank_only(tmp_path / "crank-only.h5", np.random.default_rng(7))
    diagnosis = diagnose(read_hdf5(recording), load_engine(bundled_engines()[ENGINE]))
    document = diagnosis_document(diagnosis, recording=recording.name)
    path = tmp_path / "crank-only.html"
    path.write_text(recording_page(document), encoding="utf-8")
    browser.get(path.as_uri())
    assert browser.find_element(By.CSS_SELECTOR, ".verdict .status").get_attribute("data-status") == "healthy"
    line = browser.find_element(By.ID, "bearings-not-judged")
    assert line.is_displayed() and line.text.startswith("Main bearings not judged:")
    assert "no main-bearing vibration channel" in line.text
    findings = browser.find_element(By.ID, "findings")
    charts = browser.find_element(By.ID, "charts")
    assert findings.location["y"] < line.location["y"] < charts.location["y"]
    expected = 1 + len(document["channels"])  # the cylinder balance and the crank speed
    assert int(browser.find_element(By.TAG_NAME, "body").get_attribute("data-charts")) == expected == 2


def test_a_v_engines_balance_chart_names_its_cylinders_by_bank(browser: Any, tmp_path: Path) -> None:
    """The bundled V12 sample (cylinder B3 misfiring) against a baseline of its healthy scene: the
    finding says B3, the balance chart's axis reads A1 .. A6, B1 .. B6 under the bars, and hovering
    over the ninth bar names it B3 in the legend, not 9."""
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By

    from monitor.scene import load_scene, simulate

    scene = load_scene(ROOT / "recordings" / "scenes" / "12v32-baseline.toml").model_copy(
        update={"duration_s": 6.0}
    )
    engine = load_engine(bundled_engines()["medium-speed-12v32"])
    baseline = calibrate(simulate(scene, seed=5).recording, engine, source="12v32-baseline")
    diagnosis = diagnose(read_hdf5(SAMPLES / "12v32-misfire-b3.h5"), engine, baseline=baseline)
    path = tmp_path / "v12.html"
    path.write_text(recording_page(diagnosis_document(diagnosis, recording="12v32-misfire-b3.h5")), "utf-8")
    browser.get(path.as_uri())
    assert "cylinder B3" in browser.find_element(By.ID, "findings").text
    names = [f"A{k}" for k in range(1, 7)] + [f"B{k}" for k in range(1, 7)]
    ticks = browser.execute_script(
        "var u = enginePages.charts[0], a = u.axes[0];"
        "return a.values(u, [1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12], 0, 1, 1);"
    )
    assert ticks == names
    # the cursor at the ninth bar's place (x = 9 on the chart's scale): the legend names B3
    area = browser.find_element(By.CSS_SELECTOR, "#chart-balance .u-over")
    left, width = browser.execute_script(
        "var u = enginePages.charts[0]; return [u.valToPos(9, 'x'), u.over.clientWidth];"
    )
    ActionChains(browser).move_to_element_with_offset(area, int(left - width / 2), 0).perform()
    legend = browser.find_element(By.CSS_SELECTOR, "#chart-balance .u-legend").text
    assert re.sub(r"\s+", "", legend).startswith("cylinderB3strength"), legend
