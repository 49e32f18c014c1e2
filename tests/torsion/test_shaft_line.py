"""Shaft-line model: openTorsion's textbook systems, a peer build, closed forms, balances."""

from __future__ import annotations

import math

import numpy as np
import opentorsion as ot
import pytest

from monitor.errors import ModelError
from monitor.model.crankshaft import EngineModel
from monitor.model.engine import load_engine
from monitor.model.inertia import mean_reciprocating_inertia
from monitor.model.kinematics import piston_x_derivatives
from monitor.model.predicted import predict_orders
from monitor.torsion.shaft_line import (
    GearMesh,
    Node,
    ShaftElement,
    ShaftLineModel,
    campbell,
    engine_forced_response,
    shaft_line_of,
)


def _chain(inertias: list[float], stiffnesses: list[float]) -> ShaftLineModel:
    nodes = [Node(f"n{i}", j) for i, j in enumerate(inertias)]
    shafts = [ShaftElement(i, i + 1, k) for i, k in enumerate(stiffnesses)]
    return ShaftLineModel(nodes, shafts)


def _hz(model: ShaftLineModel) -> np.ndarray:
    return model.modes().frequencies_hz


# openTorsion 0.3.2, opentorsion/tests/tests.py: the systems and the digits its tests print.
def test_opentorsion_test_shaft() -> None:
    """test_shaft: two disks 211.4 and 8.3 kg m^2 on k = 9.775e6 N m/rad -> 176.1 Hz."""
    assert np.round(_hz(_chain([211.4, 8.3], [9.775e6])), 1).tolist() == [176.1]


def test_opentorsion_friswell_example_9_7_1() -> None:
    """test_friswell_ex971: free-free chain -> 81.21, 141.21, 378.95, 536.36 Hz (Friswell ex. 9.7.1)."""
    model = _chain([3.5e-3, 3.5e-3, 3.5e-3, 0.15, 0.05], [12e3, 12e3, 14e3, 10e3])
    assert np.round(_hz(model), 2).tolist() == [81.21, 141.21, 378.95, 536.36]


def test_opentorsion_friswell_page_x_branched_gears() -> None:
    """test_friswell_pagex: motor, 1:1 gear pair, two branches -> 425.4, 634.1, 3247.2 Hz."""
    nodes = [
        Node("motor", 400e-6),
        Node("gear 1", 25e-6),
        Node("gear 2", 25e-6),
        Node("load a", 700e-6),
        Node("load b", 700e-6),
    ]
    shafts = [ShaftElement(0, 1, 10000), ShaftElement(2, 3, 5000), ShaftElement(1, 4, 5000)]
    model = ShaftLineModel(nodes, shafts, [GearMesh(1, 2, 1.0, 1.0)])
    assert np.round(_hz(model), 1).tolist() == [425.4, 634.1, 3247.2]


def test_opentorsion_friswell_9_6_3_geared_branches() -> None:
    """test_friswell_ex971, second part (Friswell 9.6.3): a gear box with two branches
    -> 10.304, 20.479, 24.423 Hz."""
    g, d = 68e9, 0.2
    k1 = g * math.pi * d**4 / 32 / 2.5
    k2 = g * math.pi * 0.25**4 / 32 / 3.5
    nodes = [
        Node("engine", 3200),
        Node("gear 1", 200),
        Node("gear 2", 200),
        Node("gear 3", 800),
        Node("gear 4", 800),
        Node("load 1", 450),
        Node("load 2", 450),
    ]
    shafts = [ShaftElement(0, 1, k1), ShaftElement(3, 5, k2), ShaftElement(4, 6, k2)]
    gears = [GearMesh(1, 2, 0.5, 0.5), GearMesh(1, 3, 0.5, 0.8), GearMesh(2, 4, 0.5, 0.8)]
    model = ShaftLineModel(nodes, shafts, gears)
    assert np.round(_hz(model), 3).tolist() == [10.304, 20.479, 24.423]


@pytest.mark.parametrize(
    ("elements", "expected"),
    [
        (5, [1.9417, 4.0719, 6.5437, 9.1547]),
        (8, [1.9225, 3.9187, 6.0625, 8.4185]),
        (50, [1.9106, 3.8232, 5.7394, 7.6613]),
    ],
)
def test_opentorsion_friswell_9_9_distributed_shaft(elements: int, expected: list[float]) -> None:
    """test_friswell_09_09: a hollow shaft (k 1 763 872 N m/rad, inertia 120 414 kg m^2 in all) in
    consistent elements between disks of 200 and 10 kg m^2; first four frequencies to 4 decimals."""
    od, idia, length, g, rho = 0.78, 0.65, 800.0, 75e9, 8000.0
    polar = math.pi * (od**4 - idia**4) / 32
    k_total, i_total = g * polar / length, rho * polar * length
    nodes = [Node(f"n{i}", 0.0) for i in range(elements + 1)]
    nodes[0] = Node("n0", 200.0)
    nodes[-1] = Node(f"n{elements}", 10.0)
    shafts = [ShaftElement(i, i + 1, k_total * elements, inertia=i_total / elements) for i in range(elements)]
    assert np.round(_hz(ShaftLineModel(nodes, shafts))[:4], 4).tolist() == expected


def test_engine_shaft_line_matches_opentorsion_to_1e_6() -> None:
    """The 7K98MC shaft line built in openTorsion straight from the engine description (disks and
    massless shafts, assembled by openTorsion, not from our nodes) gives the same natural
    frequencies as shaft_line_of to 1e-6 relative."""

    e = load_engine("man-b-w-7k98mc")
    line = e.shaft_line
    assert line is not None
    throw = line.throw_inertia_kgm2 + e.rotating_rod_mass * e.crank_radius**2 + mean_reciprocating_inertia(e)
    inertias = [el.inertia_kgm2 for el in reversed(line.free_end)] + [throw] * e.cylinders
    inertias += [el.inertia_kgm2 for el in line.driven_end]
    stiffnesses = [el.stiffness_to_previous_nm_per_rad for el in reversed(line.free_end)]
    stiffnesses += [line.throw_stiffness_nm_per_rad] * (e.cylinders - 1)
    stiffnesses += [el.stiffness_to_previous_nm_per_rad for el in line.driven_end]
    disks = [ot.Disk(i, I=inertia) for i, inertia in enumerate(inertias)]
    shafts = [ot.Shaft(i, i + 1, k=k) for i, k in enumerate(stiffnesses)]
    assembly = ot.Assembly(shafts, disk_elements=disks)
    wn, _, _ = assembly.modal_analysis(C=np.zeros_like(assembly.M))
    theirs = np.unique(np.round(np.sort(wn), 6))  # each frequency comes as a conjugate pair
    theirs = theirs[theirs > 1e-3]
    np.testing.assert_allclose(shaft_line_of(e).modes().frequencies, theirs, rtol=1e-6)


def test_two_disks_closed_form() -> None:
    model = _chain([2.0, 3.0], [600.0])
    assert model.modes().frequencies[0] == pytest.approx(math.sqrt(600.0 * (2 + 3) / 6.0), rel=1e-14)


def test_consistent_elements_converge_to_the_continuous_shaft() -> None:
    """Free-free uniform shaft: w_n = n pi sqrt(k_total / I_total); consistent elements converge as h^2."""
    k_total, i_total = 1.0e6, 50.0
    errors = []
    for n in (8, 16, 32):
        nodes = [Node(f"n{i}", 0.0) for i in range(n + 1)]
        shafts = [ShaftElement(i, i + 1, k_total * n, inertia=i_total / n) for i in range(n)]
        w = ShaftLineModel(nodes, shafts).modes().frequencies[:3]
        exact = np.arange(1, 4) * math.pi * math.sqrt(k_total / i_total)
        errors.append(np.abs(w / exact - 1).max())
    assert errors[0] / errors[1] == pytest.approx(4.0, rel=0.05)
    assert errors[1] / errors[2] == pytest.approx(4.0, rel=0.05)


def test_lumped_and_consistent_models_differ_as_expected() -> None:
    """The lumped shaft mass underestimates the frequencies of a coarse distributed shaft."""
    nodes = [Node(f"n{i}", 0.0) for i in range(5)]
    consistent = ShaftLineModel(nodes, [ShaftElement(i, i + 1, 4e6, inertia=10.0) for i in range(4)])
    lumped = ShaftLineModel(
        nodes, [ShaftElement(i, i + 1, 4e6, inertia=10.0, mass_model="lumped") for i in range(4)]
    )
    assert np.all(lumped.modes().frequencies < consistent.modes().frequencies)


def test_power_balance_of_the_forced_response() -> None:
    """Mean power input by the torques equals the power dissipated by the dampers."""
    nodes = [Node("a", 10.0), Node("b", 4.0, damping_to_ground=30.0), Node("c", 7.0)]
    model = ShaftLineModel(nodes, [ShaftElement(0, 1, 1e5, damping=12.0), ShaftElement(1, 2, 2e5)])
    w = 95.0
    torque = np.array([100.0, 0.0, 40.0 * np.exp(0.7j)])
    angles, _ = model.harmonic_response(w, torque)
    power_in = 0.5 * np.real(np.vdot(1j * w * angles, torque))
    dissipated = 0.5 * w**2 * np.real(np.conj(angles) @ model.damping @ angles)
    assert power_in == pytest.approx(dissipated, rel=1e-10)


def test_rigid_engine_response_is_the_total_torque_over_the_total_inertia() -> None:
    """A nearly rigid shaft line (stiffness x 1e6): each order's response is -T_k / (w_k^2 J_total),
    with T_k the engine's torque order: the cylinders' phases add up correctly. The residual
    flexibility (w_k / w_1)^2, about (6 Hz / 3.3 kHz)^2 = 3e-6 here, sets the tolerance 1e-5."""
    e = load_engine("man-b-w-7k98mc")
    line = shaft_line_of(e)
    stiff = ShaftLineModel(
        [Node(n.name, n.inertia) for n in line.nodes],
        [ShaftElement(s.node_a, s.node_b, s.stiffness * 1e6) for s in line.shafts],
    )
    speed = e.rated_speed * 0.5
    response = engine_forced_response(e, [speed], load=0.6, line=stiff, max_order=14)

    torque = predict_orders(EngineModel(e), crank_speed=speed, load=0.6, max_order=14).engine_torque[1:]
    total_inertia = sum(n.inertia for n in line.nodes)
    expected = -torque / ((response.orders * speed) ** 2 * total_inertia)
    flywheel = line.index("turning wheel")
    np.testing.assert_allclose(
        response.angle[flywheel, 0], expected, rtol=1e-5, atol=1e-6 * np.abs(expected).max()
    )


def test_campbell_critical_speeds() -> None:
    e = load_engine("man-b-w-7k98mc")
    modes = shaft_line_of(e).modes()
    data = campbell(modes, np.arange(1, 13), (20.0, 115.0))
    for mode, order, rpm in data.critical_speeds_rpm:
        assert order * rpm / 60 == pytest.approx(modes.frequencies_hz[mode - 1])
        assert 20.0 <= rpm <= 115.0


def test_undamped_resonance_is_refused() -> None:
    model = _chain([2.0, 3.0], [600.0])
    w = model.modes().frequencies[0]
    with pytest.raises(ModelError, match="singular"):
        model.harmonic_response(w, [1.0, 0.0])


@pytest.mark.parametrize(
    ("nodes", "shafts", "message"),
    [
        ([Node("a", -1.0)], [], "inertia = -1.0"),
        ([Node("a", 1.0), Node("b", 1.0)], [ShaftElement(0, 0, 1.0)], "two different nodes"),
        ([Node("a", 1.0), Node("b", 1.0)], [ShaftElement(0, 1, 0.0)], "stiffness = 0.0"),
        ([], [], "at least one node"),
    ],
)
def test_bad_models_are_refused(nodes: list[Node], shafts: list[ShaftElement], message: str) -> None:
    with pytest.raises(ModelError, match=message):
        ShaftLineModel(nodes, shafts)


def test_engine_without_shaft_line_is_refused() -> None:
    with pytest.raises(ModelError, match="has no \\[shaft_line\\]"):
        shaft_line_of(load_engine("kluczyk-1cyl-4stroke"))


def test_mean_reciprocating_inertia_of_the_exact_kinematics() -> None:
    """Mean of m_rec x'^2 over a revolution: m_rec R^2 (1/2 + lambda^2/8 + lambda^4/... ), here
    against a 20 000-point trapezoid (an independent quadrature); it tends to m R^2 / 2 as lambda -> 0."""

    e = load_engine("man-b-w-7k98mc")
    a = np.linspace(0, 2 * np.pi, 20001)
    dx = piston_x_derivatives(a, e.crank_radius, e.rod_ratio)[1]
    reference = e.reciprocating_mass * np.trapezoid(dx**2, a) / (2 * np.pi)
    assert mean_reciprocating_inertia(e) == pytest.approx(reference, rel=1e-12)
    ratio = mean_reciprocating_inertia(e) / (0.5 * e.reciprocating_mass * e.crank_radius**2)
    assert ratio == pytest.approx(1 + e.rod_ratio**2 / 4, rel=0.01)


def test_natural_frequencies_through_a_revolution() -> None:
    """With the reciprocating inertia at each crank angle, the frequencies move around their mean-inertia
    values; with no reciprocating inertia they are higher than all of them."""
    e = load_engine("man-b-w-7k98mc")
    mean = shaft_line_of(e).modes().frequencies
    none = shaft_line_of(e, reciprocating="none").modes().frequencies
    through = np.array(
        [
            shaft_line_of(e, reciprocating=float(a)).modes().frequencies
            for a in np.linspace(0, 2 * np.pi, 24, endpoint=False)
        ]
    )
    assert np.all(through.min(axis=0) <= mean * (1 + 1e-9)) and np.all(
        through.max(axis=0) >= mean * (1 - 1e-9)
    )
    assert np.all(none > through.max(axis=0))
    with pytest.raises(ModelError, match="expected 'mean', 'none' or a crank angle"):
        shaft_line_of(e, reciprocating="max")  # type: ignore[arg-type]
