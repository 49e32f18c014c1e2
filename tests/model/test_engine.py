"""Engine descriptions: bundled files load; bad descriptions are refused with field, value and rule."""

from __future__ import annotations

import copy
import math
import tomllib
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from monitor.errors import EngineDescriptionError
from monitor.model.engine import bundled_engines, load_engine, parse_engine
from tests.conftest import ENGINES


def _base() -> dict[str, Any]:
    with (ENGINES / "man-b-w-7k98mc.toml").open("rb") as handle:
        return tomllib.load(handle)


def test_bundled_engines_load() -> None:
    ids = set(bundled_engines())
    assert {"man-b-w-7k98mc", "kluczyk-1cyl-4stroke", "zubaydi-1cyl-2stroke", "medium-speed-6l32"} <= ids
    for path in bundled_engines().values():
        engine = load_engine(path)
        assert engine.id == path.stem


def test_7k98mc_si_values() -> None:
    """Paper 000: lambda = 0.413, bore 0.98 m, stroke 2.66 m, 104 rpm."""
    e = load_engine("man-b-w-7k98mc")
    assert e.rod_ratio == pytest.approx(0.413)
    assert e.crank_radius == pytest.approx(1.33)
    assert e.rod_length == pytest.approx(1.33 / 0.413)
    assert e.rated_speed == pytest.approx(104 * math.pi / 30)
    assert e.cycle_revolutions == 1 and e.bearing_count == 8


def test_even_firing_angles_from_firing_order() -> None:
    two = load_engine("man-b-w-7k98mc")  # 1-7-2-5-4-3-6, every 360/7 deg
    expected = {1: 0, 7: 1, 2: 2, 5: 3, 4: 4, 3: 5, 6: 6}
    for cyl, position in expected.items():
        assert math.degrees(two.firing_angles[cyl - 1]) == pytest.approx(position * 360 / 7)
    four = load_engine("medium-speed-6l32")  # 1-5-3-6-2-4 every 120 deg of 720
    np.testing.assert_allclose(np.degrees(four.firing_angles), [0, 480, 240, 600, 120, 360])


def test_explicit_uneven_firing_angles_must_match_the_order() -> None:
    data = _base()
    data["firing"]["angles_deg"] = [0, 100, 260, 200, 150, 310, 50]
    engine = parse_engine(data)
    assert math.degrees(engine.firing_angles[1]) == pytest.approx(100)
    data["firing"]["angles_deg"] = [0, 50, 260, 150, 200, 310, 100]
    with pytest.raises(EngineDescriptionError, match=r"fire the cylinders in the order \[1, 2, 7"):
        parse_engine(data)


def test_bearing_share_carries_each_throw_once() -> None:
    e = load_engine("man-b-w-7k98mc")
    np.testing.assert_allclose(e.bearing_share.sum(axis=0), 1.0)
    data = _base()
    data["bearings"] = {"positions_m": [0.0, 1.5, 3.25, 5.0, 6.75, 8.5, 10.25, 12.0]}
    # cylinder 1 sits at 0.75 m between bearings at 0 and 1.5 m: half each; cylinder 2 at 2.5 m
    share = parse_engine(data).bearing_share
    assert share[0, 0] == pytest.approx(0.5) and share[1, 0] == pytest.approx(0.5)
    assert share[2, 1] == pytest.approx((2.5 - 1.5) / 1.75)


def _refused(mutate: Any, *fragments: str) -> None:
    data = copy.deepcopy(_base())
    mutate(data)
    with pytest.raises(EngineDescriptionError) as info:
        parse_engine(data, origin="test.toml")
    message = str(info.value)
    for fragment in fragments:
        assert fragment in message, message


def test_rod_ratio_at_or_above_one_is_refused() -> None:
    _refused(
        lambda d: d["geometry"].update(rod_ratio=1.0),
        "geometry",
        "rod_ratio = 1.0",
        "expected 0 < crank radius / rod length < 1",
    )

    def short_rod(d: dict[str, Any]) -> None:
        del d["geometry"]["rod_ratio"]
        d["geometry"]["rod_length_m"] = 1.0

    _refused(short_rod, "rod_length_m = 1.0 gives rod ratio 1.33")


@pytest.mark.parametrize("value", [0.0, -6000.0, float("nan")])
def test_non_positive_mass_is_refused(value: float) -> None:
    _refused(
        lambda d: d["masses"].update(piston_assembly_kg=value),
        "masses.piston_assembly_kg",
        "expected a positive, finite value [kg]",
    )


@pytest.mark.parametrize("order", [[1, 7, 2, 5, 4, 3, 3], [1, 2, 3, 4, 5, 6], [0, 1, 2, 3, 4, 5, 6]])
def test_firing_order_not_a_permutation_is_refused(order: list[int]) -> None:
    _refused(
        lambda d: d["firing"].update(order=order),
        f"firing.order = {order}",
        "permutation of the cylinders 1..7",
    )


def test_missing_field_is_refused() -> None:
    _refused(lambda d: d["masses"].pop("conrod_kg"), "masses.conrod_kg: required field is missing")


def test_unit_typo_in_a_field_name_is_refused_with_a_suggestion() -> None:
    def typo(d: dict[str, Any]) -> None:
        d["geometry"]["bore_mm"] = d["geometry"].pop("bore_m")

    _refused(
        typo,
        "geometry.bore_mm: unknown field; did you mean 'bore_m'?",
        "geometry.bore_m: required field is missing",
    )


def test_unit_typo_in_a_value_is_refused_with_a_hint() -> None:
    _refused(
        lambda d: d["geometry"].update(bore_m=980.0),
        "geometry.bore_m = 980.0",
        "expected 0.01 <= value <= 1.5 m; was it given in mm?",
    )
    _refused(lambda d: d["combustion"].update(intake_pressure_bar=3.6e5), "was it given in Pa?")


def test_gas_model_is_required() -> None:
    _refused(lambda d: d.pop("combustion"), "no gas-force model: add a [combustion] table")


def test_combustion_timing_must_be_ordered() -> None:
    _refused(
        lambda d: d["combustion"].update(combustion_start_deg=120.0),
        "combustion_start_deg (120) < exhaust_opening_deg (110)",
    )


def test_unreadable_files_are_refused(tmp_path: Path) -> None:
    with pytest.raises(EngineDescriptionError, match="no such engine file"):
        load_engine(tmp_path / "missing.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("id = \n")
    with pytest.raises(EngineDescriptionError, match="not valid TOML"):
        load_engine(bad)


def test_blowdown_past_the_next_inlet_closing_is_refused_when_loading() -> None:
    """Review finding: this was found only when the model was built; the description now refuses it."""
    _refused(
        lambda d: d["combustion"].update(exhaust_opening_deg=170.0, blowdown_deg=90.0),
        "exhaust_opening_deg + blowdown_deg = 260 deg reaches past the next inlet closing at 250 deg",
    )
