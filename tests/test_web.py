"""The web pages in a real headless Chromium: what a watch engineer sees first, charts that zoom and hover."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import pytest

from monitor.diagnosis import calibrate, diagnose
from monitor.diagnosis.report import diagnosis_document
from monitor.engine import bundled_engines, load_engine
from monitor.io.hdf5 import read_hdf5
from monitor.web import recording_page

ROOT = Path(__file__).resolve().parents[1]
SAMPLES = ROOT / "recordings" / "samples"


@pytest.fixture(scope="module")
def alarm_document() -> dict[str, Any]:
    """The bundled misfire recording diagnosed against a baseline calibrated on the healthy one."""
    engine = load_engine(bundled_engines()["man-b-w-7k98mc"])
    baseline = calibrate(read_hdf5(SAMPLES / "7k98mc-baseline.h5"), engine, source="7k98mc-baseline.h5")
    diagnosis = diagnose(read_hdf5(SAMPLES / "7k98mc-misfire-cyl4.h5"), engine, baseline=baseline)
    return diagnosis_document(diagnosis, recording="7k98mc-misfire-cyl4.h5")


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


def _screenshot(browser: Any, folder: Path, name: str) -> Path:
    """Save the page as the test sees it: under the test's folder, and under $ENGINE_MONITOR_SCREENSHOTS
    too when set (``make screenshots`` writes the docs' pictures that way)."""
    import os
    import shutil

    path = folder / f"{name}.png"
    browser.save_screenshot(str(path))
    assert path.stat().st_size > 10_000
    wanted = os.environ.get("ENGINE_MONITOR_SCREENSHOTS")
    if wanted:
        Path(wanted).mkdir(parents=True, exist_ok=True)
        shutil.copy(path, Path(wanted) / path.name)
    return path


def test_the_service_pages_log_in_and_show_the_fleet_an_engine_and_a_recording(
    browser: Any, tmp_path: Path
) -> None:
    """Recordings uploaded here, analysed by the service; a browser logs in with fleet a's key through the
    form and finds each engine's latest verdict on the fleet page (as GET /fleet says), the engine page
    with its charts and trend findings, the recording page with the alarm and its finding on top; fleet
    b's engine and recording answer 404 to it, pages and JSON alike."""
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import WebDriverWait

    from tests.test_api import _upload, _wait_done, two_fleet_server

    server = two_fleet_server(tmp_path)
    try:
        with server.client("a") as a, server.client("b") as b:
            ids = {
                name: int(_upload(a, SAMPLES / name).json()["id"])
                for name in ("7k98mc-baseline.h5", "7k98mc-misfire-cyl4.h5")
            }
            theirs = int(_upload(b, SAMPLES / "6l32-misfire-cyl3.h5").json()["id"])
            for recording in ids.values():
                assert _wait_done(a, recording)["status"] == "done"
            assert _wait_done(b, theirs)["status"] == "done"
            fleet = a.get("/fleet").json()
            assert [e["engine_id"] for e in fleet["engines"]] == ["man-b-w-7k98mc"]
            assert a.get("/engines/medium-speed-6l32/trend").status_code == 404  # fleet b's only
            assert a.get(f"/ui/recordings/{theirs}").status_code == 404
            trend = a.get("/engines/man-b-w-7k98mc/trend").json()
            assert len(trend["quantities"]["cylinder 4 strength"]["points"]) == 2
        browser.delete_all_cookies()
        browser.get(f"{server.url}/ui")
        assert "/login" in browser.current_url  # no session: the login first
        browser.find_element(By.ID, "key").send_keys(server.keys["a"])
        browser.find_element(By.CSS_SELECTOR, "form button[type=submit]").click()
        # the form's answer is a redirect the browser follows after click() returns: wait for it
        WebDriverWait(browser, 30).until(lambda page: page.current_url.endswith("/ui"))
        rows = browser.find_elements(By.CSS_SELECTOR, "#fleet .engine-row")
        assert [(r.get_attribute("data-engine"), r.get_attribute("data-status")) for r in rows] == [
            (e["engine_id"], e["latest"]["status"]) for e in fleet["engines"]
        ]
        _screenshot(browser, tmp_path, "fleet")
        rows[0].find_element(By.CSS_SELECTOR, "a").click()  # the engine
        WebDriverWait(browser, 30).until(lambda page: "/ui/engines/man-b-w-7k98mc" in page.current_url)
        assert browser.find_element(By.ID, "trend-findings").text
        assert int(browser.find_element(By.TAG_NAME, "body").get_attribute("data-charts")) >= 2
        _screenshot(browser, tmp_path, "engine")
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
    finally:
        server.kill()


def test_the_wheel_carries_every_script_and_style_the_pages_load(tmp_path: Path) -> None:
    """No step downloads anything at build or run time: the product's wheel (built here from a copy of
    the sources, without fetching) holds every file a page refers to, the vendored chart library and
    its licence among them."""
    import shutil
    import subprocess
    import sys
    import zipfile

    from monitor.web import pages

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
    missing = [name for name in wanted if f"monitor/web/static/{name}" not in names]
    assert not missing, f"the wheel lacks {missing}"
