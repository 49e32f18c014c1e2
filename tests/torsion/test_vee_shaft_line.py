"""A V engine's shaft line: one node per crank throw carrying both its cylinders.

Each throw's inertia is checked against the sum written out from the description (the throw, two
rods' rotating shares, two cylinders' reciprocating parts), and the forced response against the
shaft line driven directly by each throw's two cylinder torques added (a response that kept one
cylinder of a throw, as an assignment by node would, fails it by the other cylinder's share).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from monitor.errors import ModelError
from monitor.model.engine import load_engine
from monitor.model.excitation import cylinder_torque_orders
from monitor.model.inertia import mean_reciprocating_inertia, node_inertias, reciprocating_inertia
from monitor.torsion.axial_coupling import AxialTorsionalCrankshaft
from monitor.torsion.shaft_line import engine_forced_response, shaft_line_of

ENGINE = "medium-speed-12v32"


def test_each_throw_is_one_node_with_both_cylinders_moving_parts() -> None:
    engine = load_engine(ENGINE)
    assert engine.shaft_line is not None
    nodes = dict(node_inertias(engine))
    rotating = engine.shaft_line.throw_inertia_kgm2 + 2 * engine.rotating_rod_mass * engine.crank_radius**2
    for k in range(1, 7):
        assert nodes[f"throw {k}"] == pytest.approx(
            rotating + 2 * mean_reciprocating_inertia(engine), rel=1e-12
        )
    assert [name for name in nodes if name.startswith("throw")] == [f"throw {k}" for k in range(1, 7)]
    # at an angle, each cylinder's reciprocating parts at its own crank angle
    at = math.radians(20.0)
    by_angle = dict(node_inertias(engine, reciprocating=at))
    a1, b1 = (float(reciprocating_inertia(engine, at - engine.firing_angles[c])) for c in (0, 6))
    assert by_angle["throw 1"] == pytest.approx(rotating + a1 + b1, rel=1e-12)


def test_the_forced_response_drives_each_throw_with_both_its_cylinders() -> None:
    engine = load_engine(ENGINE)
    speed = 700 * math.pi / 30
    response = engine_forced_response(engine, [speed], load=0.8, max_order=6)
    line = shaft_line_of(engine)
    _, orders, torque = cylinder_torque_orders(engine, [speed], load=0.8, max_order=6)
    for j, k in enumerate(orders):
        nodal = np.zeros(len(line.nodes), dtype=np.complex128)
        for c in range(engine.cylinders):
            nodal[line.index(f"throw {engine.cylinder_throw[c] + 1}")] += torque[0, c, j]
        angle, _ = line.harmonic_response(float(k * speed), nodal)
        scale = float(np.abs(angle).max()) or 1.0
        np.testing.assert_allclose(response.angle[:, 0, j], angle, rtol=0, atol=1e-9 * scale)


def test_the_coupled_axial_model_refuses_a_v_engine() -> None:
    with pytest.raises(ModelError, match="V engine"):
        AxialTorsionalCrankshaft.of_engine(load_engine(ENGINE))
