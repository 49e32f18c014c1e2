"""Torsional-axial coupling (paper 001): independence without C14, reciprocity, condensation, hard cases."""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest
import scipy.linalg

from monitor.errors import ModelError
from monitor.model.engine import load_engine, parse_engine
from monitor.torsion.axial_coupling import (
    AxialTorsionalCrankshaft,
    CrankFlexibility,
    condense,
    constrained_coupling,
    engine_axial_response,
    pair_coupling,
    pair_flexibility,
    rotate_flexibility,
)
from monitor.torsion.shaft_line import shaft_line_of
from tests.conftest import ENGINES

C14 = pair_coupling(3e-10, 4e-10, 1e-9, 2e-9, math.radians(360 / 7 / 2))


def _shaft(coupling: float, damping: float = 1e-4) -> AxialTorsionalCrankshaft:
    cranks = [CrankFlexibility(5e-10, 1e-10, coupling)] * 7
    return AxialTorsionalCrankshaft(
        cranks,
        pin_mass=[30000.0] * 7,
        pin_inertia=[50000.0] * 7,
        journal_mass=8000.0,
        journal_inertia=2000.0,
        axial_support={7: 5e9},
        stiffness_damping=damping,
    )


def _torques(model: AxialTorsionalCrankshaft, amplitude: float = 1e6) -> np.ndarray:
    t = np.zeros(model.n_nodes, dtype=complex)
    t[1::2] = amplitude * np.exp(1j * 2 * np.pi * np.arange(7) / 7 * 3)
    return t


def test_without_coupling_axial_and_torsional_motion_are_independent() -> None:
    model = _shaft(0.0)
    for w in (2 * np.pi * 5, 2 * np.pi * 23.0, 2 * np.pi * 61.0):
        torsion_only = model.harmonic_response(w, torque=_torques(model))
        assert np.abs(torsion_only.axial).max() == 0.0
        axial_only = model.harmonic_response(w, axial_force=np.full(model.n_nodes, 1e5))
        assert np.abs(axial_only.twist).max() == 0.0
    _, share = model.modes()
    assert np.all((share < 1e-12) | (share > 1 - 1e-12))


def test_coupling_makes_torsion_move_the_shaft_axially() -> None:
    model = _shaft(C14)
    response = model.harmonic_response(2 * np.pi * 20, torque=_torques(model))
    assert np.abs(response.axial).max() > 1e-6  # micrometres and more under MN m torques
    _, share = model.modes()
    assert np.any((share > 0.01) & (share < 0.99))  # some modes mix the two motions


def test_reciprocity_of_the_cross_receptances() -> None:
    """Maxwell-Betti: the axial displacement at i per unit torque at j equals the twist at j
    per unit axial force at i."""
    model = _shaft(C14)
    w = 2 * np.pi * 17.0
    for i, j in ((0, 5), (3, 9), (14, 1)):
        torque = np.zeros(model.n_nodes, dtype=complex)
        torque[j] = 1.0
        force = np.zeros(model.n_nodes, dtype=complex)
        force[i] = 1.0
        a = model.harmonic_response(w, torque=torque).axial[i]
        b = model.harmonic_response(w, axial_force=force).twist[j]
        assert a == pytest.approx(b, rel=1e-9)


def test_condensation_gives_the_full_solution() -> None:
    """001 eq. 3-7 through the journals equals solving the whole system directly."""
    model = _shaft(C14)
    w = 2 * np.pi * 33.0
    h = np.zeros(2 * model.n_nodes, dtype=complex)
    h[1::2] = _torques(model)
    full = scipy.linalg.solve(model.dynamic_stiffness(w), h)
    response = model.harmonic_response(w, torque=_torques(model))
    assert response.condensed
    np.testing.assert_allclose(response.twist, full[1::2], rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(response.axial, full[0::2], rtol=1e-9, atol=1e-15)


def test_singular_inner_block_falls_back_to_the_full_solve() -> None:
    """At the pin's own resonance on fixed journals B_BB is singular: condensation is skipped and
    the (well-posed) full system is solved; the residual proves it."""
    model = _shaft(C14, damping=0.0)
    pin = [2, 3]  # u and phi of pin 1
    values = scipy.linalg.eigh(
        model.stiffness[np.ix_(pin, pin)], model.mass[np.ix_(pin, pin)], eigvals_only=True
    )
    w = float(np.sqrt(values[0]))
    response = model.harmonic_response(w, torque=_torques(model))
    assert not response.condensed and response.inner_condition > 1e10
    q = np.zeros(2 * model.n_nodes, dtype=complex)
    q[0::2], q[1::2] = response.axial, response.twist
    h = np.zeros(2 * model.n_nodes, dtype=complex)
    h[1::2] = _torques(model)
    residual = model.dynamic_stiffness(w) @ q - h
    assert np.abs(residual).max() <= 1e-6 * np.abs(h).max()


def test_undamped_resonance_of_the_whole_crankshaft_is_refused() -> None:
    model = _shaft(C14, damping=0.0)
    w = float(model.modes()[0][0])
    with pytest.raises(ModelError, match=r"singular .* an undamped resonance"):
        model.harmonic_response(w, torque=_torques(model))


def test_condense_refuses_an_ill_conditioned_inner_block() -> None:
    b = np.array([[2.0, 1.0, 0.0], [1.0, 1.0, 1.0], [0.0, 1.0, 1.0 + 1e-13]], dtype=complex)
    with pytest.raises(ModelError, match="ill-conditioned"):
        condense(b, np.ones(3, dtype=complex), [0])


def test_torsion_drives_axial_motion_far_more_than_the_reverse() -> None:
    """001 Fig. 1: with MN m gas torques on the throws and a 100 kN propeller thrust fluctuation,
    the axial motion torsion causes is far larger, relative to the axial motion the thrust causes,
    than the twist the thrust causes relative to the twist the torques cause."""
    model = _shaft(C14)
    w = 2 * np.pi * 12.0
    by_torque = model.harmonic_response(w, torque=_torques(model, 2e6))
    thrust = np.zeros(model.n_nodes, dtype=complex)
    thrust[-1] = 1e5
    by_thrust = model.harmonic_response(w, axial_force=thrust)
    axial_ratio = np.abs(by_torque.axial).max() / np.abs(by_thrust.axial).max()
    twist_ratio = np.abs(by_thrust.twist).max() / np.abs(by_torque.twist).max()
    assert axial_ratio > 100 * twist_ratio


def test_pair_coupling_formula() -> None:
    """Eq. 1: zero for cranks in line (delta 0) or opposite (delta 90 deg), odd in delta."""
    assert pair_coupling(3e-10, 4e-10, 1e-9, 2e-9, 0.0) == 0.0
    typical = pair_coupling(3e-10, 4e-10, 1e-9, 2e-9, 0.4)
    assert abs(pair_coupling(3e-10, 4e-10, 1e-9, 2e-9, math.pi / 2)) < 1e-15 * typical  # cos(pi/2) ~ 6e-17
    assert pair_coupling(3e-10, 4e-10, 1e-9, 2e-9, -0.4) == -pair_coupling(3e-10, 4e-10, 1e-9, 2e-9, 0.4)
    with pytest.raises(ModelError, match="positive lateral flexibilities"):
        pair_coupling(3e-10, 4e-10, 0.0, 2e-9, 0.4)


def test_flexibility_must_be_positive_definite() -> None:
    with pytest.raises(ModelError, match="positive definite"):
        CrankFlexibility(1e-10, 1e-10, 2e-10)
    with pytest.raises(ModelError, match="positive flexibilities"):
        CrankFlexibility(-1e-10, 1e-10)


def test_eq_1_from_the_single_crank_flexibilities() -> None:
    """001 eq. 1 by an independent route: the single crank's 6 x 6 flexibility (one end fixed, with the
    radial-axial term C21 and the tangential-torsional term C34 but no C14) constrained laterally along
    the bisector of a crank pair (delta from the crank plane) by a Schur complement. The constrained
    u_x / M_x equals eq. 1 (up to the sign convention of delta) for every delta."""

    c11, c22, c33, c44, c55, c66 = 5e-10, 1e-9, 2e-9, 1e-10, 3e-11, 2e-11
    c21, c34, c61, c54 = (
        3e-10,
        4e-10,
        1e-11,
        2e-11,
    )  # in-plane bending under axial force, out-of-plane under torque
    flexibility = np.diag([c11, c22, c33, c44, c55, c66])
    for i, j, v in ((1, 0, c21), (2, 3, c34), (5, 0, c61), (4, 3, c54)):
        flexibility[i, j] = flexibility[j, i] = v
    assert np.all(np.linalg.eigvalsh(flexibility) > 0)
    for delta in np.radians([10.0, 25.7, 30.0, 45.0, 60.0, 80.0]):
        assert -constrained_coupling(flexibility, delta) == pytest.approx(
            pair_coupling(c21, c34, c22, c33, delta), rel=1e-12
        )
    assert constrained_coupling(flexibility, 0.0) == 0.0  # held in the crank plane: no coupling


def _engine_with(c21: float):  # type: ignore[no-untyped-def]

    with (ENGINES / "man-b-w-7k98mc.toml").open("rb") as handle:
        data = tomllib.load(handle)
    data["shaft_line"]["axial"]["radial_per_axial_m_per_n"] = c21
    return parse_engine(data)


def test_superelement_with_held_laterals_reduces_to_eq_1() -> None:
    """A 6 x 6 superelement flexibility with one lateral direction held gives the CrankFlexibility whose
    coupling is eq. 1, and whose axial and torsional flexibilities are the constrained ones."""
    flexibility = np.diag([5e-10, 1e-9, 2e-9, 1e-10, 3e-11, 2e-11])
    flexibility[1, 0] = flexibility[0, 1] = 3e-10
    flexibility[2, 3] = flexibility[3, 2] = 4e-10
    delta = math.radians(25.7)
    reduced = CrankFlexibility.from_superelement(flexibility, [delta])
    assert -reduced.coupling == pytest.approx(pair_coupling(3e-10, 4e-10, 1e-9, 2e-9, delta), rel=1e-12)
    free = CrankFlexibility.from_superelement(flexibility, [])
    assert free.coupling == 0.0 and free.axial == 5e-10 and free.torsional == 1e-10
    both = CrankFlexibility.from_superelement(flexibility, [0.0, math.pi / 2])  # laterals fully held
    # C21 and C34 act in different lateral directions: no path between them (cos(pi/2) ~ 6e-17 aside)
    assert abs(both.coupling) < 1e-20 * abs(reduced.coupling)
    assert both.axial == pytest.approx(5e-10 - (3e-10) ** 2 / 1e-9)


def test_engine_crankshaft_couplings_follow_the_neighbouring_throws() -> None:

    e = load_engine("man-b-w-7k98mc")
    model = AxialTorsionalCrankshaft.of_engine(e)
    axial = e.shaft_line.axial  # type: ignore[union-attr]
    angles = -e.firing_angles
    delta = 0.5 * math.remainder(float(angles[1] - angles[0]), 2 * math.pi)
    expected = pair_coupling(
        axial.radial_per_axial_m_per_n,
        axial.tangential_per_torque_m_per_nm,
        axial.radial_flexibility_m_per_n,
        axial.tangential_flexibility_m_per_n,
        delta,
    )
    assert model.cranks[0].coupling == pytest.approx(expected, rel=1e-12)
    assert model.cranks[0].torsional == pytest.approx(1 / e.shaft_line.throw_stiffness_nm_per_rad)  # type: ignore[union-attr]
    frequencies, _ = model.modes()
    assert np.all(np.diff(frequencies) > 0)


def test_engine_crankshaft_carries_the_shaft_line_s_inertia_and_the_throws_mass() -> None:
    """Review finding: each throw's inertia was counted one and a half times. The coupled model's
    polar inertia is the shaft line's throws plus the flywheel, and its axial mass the throws'."""

    e = load_engine("man-b-w-7k98mc")
    model = AxialTorsionalCrankshaft.of_engine(e)
    line = shaft_line_of(e)
    throws = sum(n.inertia for n in line.nodes if n.name.startswith("cylinder"))
    flywheel = line.nodes[line.index("turning wheel")].inertia
    diagonal = np.diag(model.mass)
    assert diagonal[1::2].sum() == pytest.approx(throws + flywheel, rel=1e-12)
    assert diagonal[0::2].sum() == pytest.approx(e.cylinders * e.shaft_line.axial.throw_mass_kg, rel=1e-12)  # type: ignore[union-attr]


def test_engine_axial_response_is_first_order_in_the_coupling() -> None:
    """Torsion-driven axial motion is proportional to C14 (so to C21) away from resonance: doubling C21
    doubles it within the second-order change of the modes; with C21 = 0 there is none."""

    speeds = np.array([0.5, 0.75]) * (104 * math.pi / 30)
    responses = [engine_axial_response(_engine_with(c21), speeds, max_order=8) for c21 in (1.5e-10, 3.0e-10)]
    ratio = np.abs(responses[1].axial[0]).sum() / np.abs(responses[0].axial[0]).sum()
    assert ratio == pytest.approx(2.0, rel=0.02)
    none = engine_axial_response(_engine_with(0.0), speeds, max_order=8)
    assert np.abs(none.axial).max() == 0.0


def test_engine_without_axial_data_is_refused() -> None:

    with pytest.raises(ModelError, match=r"no \[shaft_line.axial\] data"):
        AxialTorsionalCrankshaft.of_engine(load_engine("medium-speed-6l32"))


def test_a_crank_pair_reproduces_eq_1() -> None:
    """001 Fig. 3 and eq. 1: two identical cranks 2 delta apart in series, the journal between them held
    by its bearing along their bisector, axial force and torque at the outer journal. Each crank's own
    flexibility has no C14; the pair's u_x / M_x is eq. 1 for every delta, from the single-crank C21, C34,
    C22, C33 alone; and it vanishes when the middle bearing is left out."""

    c11, c22, c33, c44 = 5e-10, 1e-9, 2e-9, 1e-10
    c21, c34 = 3e-10, 4e-10
    single = np.diag([c11, c22, c33, c44, 3e-11, 2e-11])
    single[1, 0] = single[0, 1] = c21
    single[2, 3] = single[3, 2] = c34
    single[5, 0] = single[0, 5] = 1e-11
    single[4, 3] = single[3, 4] = 2e-11
    assert single[0, 3] == 0.0
    for delta in np.radians([5.0, 25.7, 45.0, 60.0, 85.0]):
        pair = pair_flexibility(single, delta)
        assert abs(pair[0, 3]) == pytest.approx(abs(pair_coupling(c21, c34, c22, c33, delta)), rel=1e-12)
        assert pair[0, 3] == pytest.approx(pair[3, 0], rel=1e-12)  # reciprocity
        unheld = rotate_flexibility(single, delta) + rotate_flexibility(single, -delta)
        assert abs(unheld[0, 3]) < 1e-30  # without the middle bearing the pair has no coupling
    assert abs(pair_flexibility(single, 0.0)[0, 3]) < 1e-30  # cranks in line
