"""The engine file's charge-pressure law: its parsing, each law's pressure, and IMEP under each law."""

from __future__ import annotations

import math
import tomllib
from typing import Any

import numpy as np
import pytest

from monitor.errors import EngineDescriptionError
from monitor.model.engine import BUNDLED_DIR, Engine, parse_engine
from monitor.model.gas import ParametricCycle

LAWS = ("turbocharged", "held", "naturally-aspirated")


def _description(engine_id: str, **combustion: Any) -> dict[str, Any]:
    """A bundled engine's description with its [combustion] table's keys replaced (None removes one)."""
    data = tomllib.loads((BUNDLED_DIR / f"{engine_id}.toml").read_text(encoding="utf-8"))
    table = dict(data["combustion"])
    for key, value in combustion.items():
        if value is None:
            table.pop(key, None)
        else:
            table[key] = value
    return {**data, "combustion": table}


def _engine(engine_id: str, law: str | None) -> Engine:
    if law == "naturally-aspirated":
        return parse_engine(_description(engine_id, charge_pressure_law=law, intake_pressure_bar=1.013))
    return parse_engine(_description(engine_id, charge_pressure_law=law))


def test_a_file_without_the_law_reads_as_turbocharged() -> None:
    """The default is the behaviour before the key existed: the bundled 6L32 with its key removed
    gives the same engine as the file that states "turbocharged"."""
    stated = parse_engine(_description("medium-speed-6l32"))
    unstated = parse_engine(_description("medium-speed-6l32", charge_pressure_law=None))
    assert stated.combustion is not None and unstated.combustion is not None
    assert stated.combustion.charge_pressure_law == "turbocharged"
    assert unstated.combustion == stated.combustion


@pytest.mark.parametrize("law", LAWS)
def test_each_law_is_parsed(law: str) -> None:
    engine = _engine("man-b-w-7k98mc", law)
    assert engine.combustion is not None and engine.combustion.charge_pressure_law == law


@pytest.mark.parametrize("bad", ["turbo", "Held", "naturally aspirated", "", 1])
def test_a_bad_law_is_refused_naming_the_allowed_values(bad: object) -> None:
    with pytest.raises(EngineDescriptionError) as error:
        parse_engine(_description("man-b-w-7k98mc", charge_pressure_law=bad))
    message = str(error.value)
    assert "combustion.charge_pressure_law" in message
    for allowed in LAWS:
        assert f"'{allowed}'" in message


def test_naturally_aspirated_with_a_charged_intake_is_refused() -> None:
    """3.6 bar of scavenge air is no naturally aspirated engine; 1.05 bar (intake ram, within 10 % of
    ambient) is."""
    with pytest.raises(EngineDescriptionError, match=r"intake_pressure_bar = 3\.6: expected about"):
        parse_engine(_description("man-b-w-7k98mc", charge_pressure_law="naturally-aspirated"))
    parse_engine(
        _description("man-b-w-7k98mc", charge_pressure_law="naturally-aspirated", intake_pressure_bar=1.05)
    )


@pytest.mark.parametrize("load", [0.0, 0.25, 0.6, 1.0, 1.1])
def test_each_laws_charge_pressure(load: float) -> None:
    """Held: the rated 3.6 bar at every load; naturally aspirated: the ambient 1.013 bar; turbocharged:
    ambient plus the load's share of the rated boost, written out here from the file's two numbers."""
    held = ParametricCycle.of(_engine("man-b-w-7k98mc", "held"))
    natural = ParametricCycle.of(_engine("man-b-w-7k98mc", "naturally-aspirated"))
    turbo = ParametricCycle.of(_engine("man-b-w-7k98mc", "turbocharged"))
    assert held.charge_pressure(load) == pytest.approx(3.6e5, rel=1e-15)
    assert natural.charge_pressure(load) == pytest.approx(1.013e5, rel=1e-15)
    assert turbo.charge_pressure(load) == pytest.approx(1.013e5 + load * (3.6e5 - 1.013e5), rel=1e-15)


def _imep_by_loop(cycle: ParametricCycle, load: float) -> float:
    """Net IMEP as the area of the p-V loop, by the trapezoidal rule in V over 40 000 angles per
    revolution: a route apart from the product's (which weights p by central differences of V on
    2880 angles per revolution)."""
    n = 40_000 * cycle.cycle_revolutions
    theta = np.linspace(0.0, 2 * math.pi * cycle.cycle_revolutions, n + 1)
    p = cycle.pressure(theta, load)
    v = cycle.volume(theta)
    return float(np.sum(0.5 * (p[1:] + p[:-1]) * np.diff(v)) / (v.max() - v.min()))


@pytest.mark.parametrize("engine_id", ["man-b-w-7k98mc", "medium-speed-6l32"])
@pytest.mark.parametrize("law", LAWS)
@pytest.mark.parametrize("load", [0.25, 0.5, 1.0])
def test_imep_is_load_times_rated_under_each_law(engine_id: str, law: str, load: float) -> None:
    """The law moves work between compression and combustion, never the IMEP: load x rated IMEP
    within 1e-4 (the two quadratures differ by their discretisation of the steep combustion rise,
    about 1e-5 of the IMEP)."""
    engine = _engine(engine_id, law)
    assert engine.combustion is not None
    imep = _imep_by_loop(ParametricCycle.of(engine), load)
    assert imep == pytest.approx(load * engine.combustion.rated_imep_bar * 1e5, rel=1e-4)


def test_the_law_changes_the_part_load_pressure_but_not_the_rated() -> None:
    """At rated load the three laws (same rated charge pressure) give one cycle; at half load held
    boost compresses more air, so it needs less heat for the same IMEP and peaks higher at TDC."""
    held = ParametricCycle.of(_engine("medium-speed-6l32", "held"))
    turbo = ParametricCycle.of(_engine("medium-speed-6l32", "turbocharged"))
    theta = np.linspace(-math.pi, math.pi, 721)
    np.testing.assert_allclose(held.pressure(theta, 1.0), turbo.pressure(theta, 1.0), rtol=1e-12)
    assert held.heat_release(0.5) < turbo.heat_release(0.5)
    assert held.pressure(np.array([0.0]), 0.5)[0] > 1.3 * turbo.pressure(np.array([0.0]), 0.5)[0]
