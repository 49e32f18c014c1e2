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
