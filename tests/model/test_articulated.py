"""The articulated (master-and-slave) rod's slave piston, by routes apart from the product's closed form.

- A numerical solution of the linkage in 40-digit arithmetic (mpmath), written here from the loop
  closure alone: the master rod's angle from the master piston staying on its bore, the slave rod's
  angle and the slave piston's place from the slave piston staying on its bore, each by Newton's
  method; the dead centres where the slave's place, differentiated numerically, stops changing.
- Finite differences of the closed form's place (its two derivatives).
- The limit of a slave rod on the crank pin: a slider-crank at the bank angle.
- The slave's loads on the crank: the torque of the statics of the rods against virtual work with the
  40-digit linkage's place differentiated numerically, and the whole linkage's equilibrium.
- The slave's moving masses: the inertia torque against the kinetic energy's rate and the free force
  against the momentum's, both from the 40-digit linkage; and the slave rod on the crank pin against
  the two-mass slider-crank of :mod:`monitor.model.forces`.
- Property tests (hypothesis) over the geometries a V engine has.
"""

from __future__ import annotations

import dataclasses
import math

import mpmath
import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from monitor.errors import ModelError
from monitor.model.articulated import ArticulatedRod
from monitor.model.kinematics import piston_x_derivatives, rod_angle

mpmath.mp.dps = 40

# a medium-speed V engine's proportions (stroke 0.4 m, rod ratio 0.25, the knuckle pin a quarter of
# the master rod from the crank pin, at the bank angle from the rod's axis, as articulated V engines
# lay it out so that the slave's stroke nearly matches the master's)
ROD = ArticulatedRod(
    crank_radius=0.2,
    master_length=0.8,
    knuckle_radius=0.2,
    knuckle_angle=math.radians(45.0),
    slave_length=0.6,
    bank_angle=math.radians(45.0),
)


def _slave_place(rod: ArticulatedRod, angle: mpmath.mpf) -> mpmath.mpf:
    """The slave piston pin's distance from the crankshaft axis, by the loop closure in mpmath."""
    radius, master, slave = (mpmath.mpf(x) for x in (rod.crank_radius, rod.master_length, rod.slave_length))
    knuckle, turn, bank = (mpmath.mpf(x) for x in (rod.knuckle_radius, rod.knuckle_angle, rod.bank_angle))
    crank = (radius * mpmath.sin(angle), radius * mpmath.cos(angle))
    # the master piston on its bore (x = 0): the rod's angle phi from the bore, crank pin x = L sin phi
    phi = mpmath.findroot(lambda f: crank[0] - master * mpmath.sin(f), mpmath.asin(crank[0] / master))
    along = (-mpmath.sin(phi), mpmath.cos(phi))  # crank pin towards the master piston pin
    across = (along[1], -along[0])
    pin = tuple(
        crank[i] + knuckle * (along[i] * mpmath.cos(turn) + across[i] * mpmath.sin(turn)) for i in (0, 1)
    )

    # the slave piston on its bore: K + l (sin psi, cos psi) = s (sin g, cos g)
    def closure(psi: mpmath.mpf, place: mpmath.mpf) -> list[mpmath.mpf]:
        return [
            pin[0] + slave * mpmath.sin(psi) - place * mpmath.sin(bank),
            pin[1] + slave * mpmath.cos(psi) - place * mpmath.cos(bank),
        ]

    _, place = mpmath.findroot(closure, (bank, pin[1] + slave))
    return place


def _dead_centre(rod: ArticulatedRod, near: float) -> mpmath.mpf:
    return mpmath.findroot(lambda a: mpmath.diff(lambda x: _slave_place(rod, x), a), mpmath.mpf(near))


def test_the_slave_stroke_and_tdc_agree_with_the_linkage_solved_to_forty_digits() -> None:
    """Issue acceptance: the slave's stroke and its TDC's offset from the bank angle, against the
    linkage solved numerically in 40 digits, to 1e-9 of the stroke (measured: 3e-16 of it, and 1e-17 rad),
    and its place at twelve crank angles as well. The articulation moves the slave's TDC 0.8 deg late
    and lengthens its stroke by 0.015 %: neither is a slider-crank's at the bank angle."""
    found = ROD.stroke()
    tdc = _dead_centre(ROD, ROD.bank_angle)
    bdc = _dead_centre(ROD, ROD.bank_angle + math.pi)
    stroke = float(_slave_place(ROD, tdc) - _slave_place(ROD, bdc))
    assert abs(found.stroke - stroke) < 1e-9 * stroke
    assert abs(found.tdc_offset - float(tdc - ROD.bank_angle)) < 1e-9
    assert abs(found.top - float(_slave_place(ROD, tdc))) < 1e-9 * stroke
    for angle in np.linspace(0.0, 2 * math.pi, 12, endpoint=False):
        exact = float(_slave_place(ROD, mpmath.mpf(angle)))
        assert float(ROD.slave_position(angle)[0]) == pytest.approx(exact, abs=1e-12 * stroke)
    assert 0.5 < math.degrees(found.tdc_offset) < 1.2
    assert found.stroke > 2 * ROD.crank_radius


def test_the_derivatives_are_the_places_finite_differences() -> None:
    """Central differences of the place at a step of 1e-4 rad: error about h^2 / 6 times the third
    derivative (below 1e-9 m/rad for the first) and h^2 / 12 times the fourth for the second (below
    1e-8 m/rad^2), far below what a wrong term would make (a tenth of the crank radius)."""
    angles = np.linspace(0.0, 2 * math.pi, 73)
    h = 1e-4
    place, first, second = ROD.slave_position(angles)
    ahead, behind = ROD.slave_position(angles + h)[0], ROD.slave_position(angles - h)[0]
    np.testing.assert_allclose(first, (ahead - behind) / (2 * h), rtol=0, atol=1e-9)
    np.testing.assert_allclose(second, (ahead - 2 * place + behind) / h**2, rtol=0, atol=1e-6)


def test_a_slave_rod_on_the_crank_pin_is_a_slider_crank_at_the_bank_angle() -> None:
    """With the knuckle radius 0 the slave is a slider-crank of its own rod at the bank angle (a
    side-by-side or fork-and-blade rod): place, velocity and acceleration to round-off, its TDC at the
    bank angle and its stroke 2 R."""
    side = ArticulatedRod(0.2, 0.8, 0.0, 0.0, 0.7, math.radians(60.0))
    angles = np.linspace(0.0, 2 * math.pi, 181)
    place, first, second = side.slave_position(angles)
    x, dx, d2x = piston_x_derivatives(angles - side.bank_angle, 0.2, 0.2 / 0.7)
    scale = 0.2
    np.testing.assert_allclose(place, 0.2 + 0.7 - x, rtol=0, atol=1e-15 * scale * 10)
    np.testing.assert_allclose(first, -dx, rtol=0, atol=1e-14 * scale)
    np.testing.assert_allclose(second, -d2x, rtol=0, atol=1e-13 * scale)
    stroke = side.stroke()
    assert stroke.tdc_offset == pytest.approx(0.0, abs=1e-12)
    assert stroke.stroke == pytest.approx(0.4, rel=1e-14)


@settings(max_examples=60, deadline=None)
@given(
    ratio=st.floats(0.15, 0.35),
    knuckle=st.floats(0.0, 0.35),
    turn=st.floats(math.radians(20.0), math.radians(80.0)),
    bank=st.floats(math.radians(40.0), math.radians(100.0)),
    slave=st.floats(0.6, 0.9),
)
def test_over_v_engine_geometries_the_dead_centres_are_the_places_extremes(
    ratio: float, knuckle: float, turn: float, bank: float, slave: float
) -> None:
    """Any V engine's proportions (rod ratio 0.15 to 0.35, the knuckle pin up to 0.35 of the master rod
    from the crank pin at 20 to 80 deg, banks 40 to 100 deg apart, the slave rod 0.6 to 0.9 of the
    master's): the dead centres the product finds are the largest and smallest place over a fine
    sweep of the crank angle, and the displacement runs from 0 to the stroke."""
    master = 1.0
    try:
        rod = ArticulatedRod(ratio, master, knuckle * master, turn, slave * master, bank)
    except ModelError:
        assume(False)  # a slave rod too short to reach its bore at every angle: refused, as tested below
    stroke = rod.stroke()
    sweep = np.linspace(0.0, 2 * math.pi, 20001)
    place = rod.slave_position(sweep)[0]
    # between samples 3e-4 rad apart the place's top is missed by at most s'' h^2 / 8, about 1e-8
    assert stroke.top == pytest.approx(place.max(), abs=1e-7)
    assert stroke.top - stroke.stroke == pytest.approx(place.min(), abs=1e-7)
    displacement = rod.slave_displacement(sweep)
    assert displacement.min() >= -1e-12 and displacement.max() <= stroke.stroke + 1e-12


@pytest.mark.parametrize(
    ("fields", "said"),
    [
        ({"knuckle_radius": 0.9}, "0 <= knuckle_radius < master_length"),
        ({"bank_angle": 0.0}, "bank_angle = 0.0 rad: expected between 0 and pi"),
        ({"slave_length": 0.15}, "it cannot reach its piston at every crank angle"),  # it strays 0.168 m
        ({"crank_radius": 0.9}, "rod_ratio"),
    ],
)
def test_a_linkage_that_cannot_work_is_refused_saying_why(fields: dict[str, float], said: str) -> None:
    with pytest.raises(ModelError, match=said):
        dataclasses.replace(ROD, **fields)


def test_the_slave_torque_of_the_rods_statics_is_virtual_works() -> None:
    """The torque the master rod's pin force puts on the crank (statics of both rods) equals the work
    the slave piston's force does per radian, ``-F ds/da``, with ``ds/da`` differentiated numerically
    from the 40-digit linkage (apart from the closed form): measured 3e-16 of the torque's scale;
    1e-9 leaves room for mpmath's numerical derivative, a wrong lever would miss by a tenth."""
    force = 1.0e6  # [N], a medium-speed engine's peak gas force
    angles = np.linspace(0.0, 2 * math.pi, 24, endpoint=False)
    loads = ROD.slave_loads(angles, force)
    work = np.array(
        [-force * float(mpmath.diff(lambda x: _slave_place(ROD, x), mpmath.mpf(a))) for a in angles]
    )
    scale = force * ROD.crank_radius
    np.testing.assert_allclose(loads.torque, work, rtol=0, atol=1e-9 * scale)


def test_the_linkage_is_in_equilibrium_under_the_slave_force() -> None:
    """The forces on the pistons and rods together (massless): the slave's axial force, both bores' and
    the crank pin's reaction sum to zero, and so do their moments about the crankshaft axis, where the
    master bore's force enters (the slave's axial force acts along a line through the axis). Both to
    round-off of the force and of its moment."""
    force = np.linspace(-2.0e5, 1.0e6, 37)  # inertia pulls, gas pushes [N]
    angles = np.linspace(0.0, 2 * math.pi, 37)
    loads = ROD.slave_loads(angles, force)
    w = np.array([math.sin(ROD.bank_angle), math.cos(ROD.bank_angle)])
    v = np.array([math.cos(ROD.bank_angle), -math.sin(ROD.bank_angle)])
    pin = np.stack([loads.pin_force_x, loads.pin_force_y], axis=-1)
    guide = loads.master_guide_force[:, None] * np.array([1.0, 0.0])
    total = -force[:, None] * w + loads.slave_guide_force[:, None] * v + guide - pin
    np.testing.assert_allclose(total, 0.0, rtol=0, atol=1e-9 * 1.0e6)

    def moment(at: np.ndarray, f: np.ndarray) -> np.ndarray:  # about the axis, from x towards y
        return np.asarray(at[:, 0] * f[:, 1] - at[:, 1] * f[:, 0])

    radius, length = ROD.crank_radius, ROD.master_length
    crank = radius * np.stack([np.sin(angles), np.cos(angles)], axis=-1)
    master_pin = np.stack([0 * angles, crank[:, 1] + np.sqrt(length**2 - crank[:, 0] ** 2)], axis=-1)
    slave_pin = ROD.slave_position(angles)[0][:, None] * w
    turning = (
        moment(slave_pin, -force[:, None] * w + loads.slave_guide_force[:, None] * v)
        + moment(master_pin, guide)
        - moment(crank, pin)
    )
    np.testing.assert_allclose(turning, 0.0, rtol=0, atol=1e-9 * 1.0e6 * length)


def test_a_slave_rod_on_the_crank_pin_loads_it_as_a_slider_crank_at_the_bank_angle() -> None:
    """With the knuckle radius 0 the slave's force reaches the crank pin as a slider-crank's at the
    bank angle (rod force ``F / cos b``, along its rod), turned into the master's frame; the master's
    bore takes nothing of it."""
    side = ArticulatedRod(0.2, 0.8, 0.0, 0.0, 0.7, math.radians(60.0))
    angles = np.linspace(0.0, 2 * math.pi, 181)
    force = 5.0e5
    loads = side.slave_loads(angles, force)
    beta = rod_angle(angles - side.bank_angle, 0.2 / 0.7)
    along = force / np.cos(beta)
    own = np.stack([along * np.sin(beta), -along * np.cos(beta)], axis=-1)  # the slave's frame
    g = side.bank_angle
    turned = own[:, :1] * np.array([math.cos(g), -math.sin(g)]) + own[:, 1:] * np.array(
        [math.sin(g), math.cos(g)]
    )
    np.testing.assert_allclose(loads.pin_force_x, turned[:, 0], rtol=0, atol=1e-9 * force)
    np.testing.assert_allclose(loads.pin_force_y, turned[:, 1], rtol=0, atol=1e-9 * force)
    np.testing.assert_allclose(loads.slave_rod_force, along, rtol=1e-12)
    np.testing.assert_allclose(loads.master_guide_force, 0.0, rtol=0, atol=1e-9 * force)


def _linkage_derivatives(rod: ArticulatedRod, angle: float, order: int) -> tuple[float, np.ndarray]:
    """The ``order``-th derivatives of the slave's place and of the knuckle pin's position in the crank
    angle, differentiated numerically from the 40-digit linkage."""
    at = mpmath.mpf(angle)
    place = float(mpmath.diff(lambda x: _slave_place(rod, x), at, order))
    pin = np.array([float(mpmath.diff(lambda x, i=i: _knuckle_pin(rod, x)[i], at, order)) for i in (0, 1)])
    return place, pin


def _knuckle_pin(rod: ArticulatedRod, angle: mpmath.mpf) -> tuple[mpmath.mpf, mpmath.mpf]:
    """The knuckle pin's position by the master's loop closure in mpmath (as :func:`_slave_place`)."""
    radius, master = mpmath.mpf(rod.crank_radius), mpmath.mpf(rod.master_length)
    knuckle, turn = mpmath.mpf(rod.knuckle_radius), mpmath.mpf(rod.knuckle_angle)
    crank = (radius * mpmath.sin(angle), radius * mpmath.cos(angle))
    phi = mpmath.asin(crank[0] / master)
    along = (-mpmath.sin(phi), mpmath.cos(phi))
    across = (along[1], -along[0])
    return (
        crank[0] + knuckle * (along[0] * mpmath.cos(turn) + across[0] * mpmath.sin(turn)),
        crank[1] + knuckle * (along[1] * mpmath.cos(turn) + across[1] * mpmath.sin(turn)),
    )


def test_the_slaves_inertia_torque_is_its_kinetic_energys_rate_and_its_free_force_its_momentums() -> None:
    """At a constant speed (no gas, no weights) the slave's inertia torque is ``-dE/da``, ``E`` the kinetic
    energy of its piston share and its knuckle share, and its force on the engine ``-sum m a``, with the
    places' derivatives taken numerically from the 40-digit linkage (apart from the closed form and the
    statics). A knuckle share left on the crank pin, or the piston's inertia with the wrong sign, misses
    by a tenth of the scale; 1e-9 leaves room for mpmath's numerical derivatives."""
    omega, piston, knuckle = 60.0, 120.0, 45.0  # 573 rpm, a medium-speed engine's masses [kg]
    angles = np.linspace(0.0, 2 * math.pi, 12, endpoint=False)
    forces = ROD.slave_train_forces(
        angles, crank_speed=omega, gas_force=0.0, reciprocating_mass=piston, knuckle_mass=knuckle, gravity=0.0
    )
    w = np.array([math.sin(ROD.bank_angle), math.cos(ROD.bank_angle)])
    torque, free = [], []
    for a in angles:
        (ds, dk), (d2s, d2k) = (_linkage_derivatives(ROD, float(a), n) for n in (1, 2))
        torque.append(-(omega**2) * (piston * ds * d2s + knuckle * float(dk @ d2k)))
        free.append(-(omega**2) * (piston * d2s * w + knuckle * d2k))
    scale = (piston + knuckle) * ROD.crank_radius * omega**2
    np.testing.assert_allclose(forces.loads.torque, torque, rtol=0, atol=1e-9 * scale * ROD.crank_radius)
    np.testing.assert_allclose(forces.inertia_force_x, np.array(free)[:, 0], rtol=0, atol=1e-9 * scale)
    np.testing.assert_allclose(forces.inertia_force_y, np.array(free)[:, 1], rtol=0, atol=1e-9 * scale)


@pytest.mark.parametrize(
    ("knuckle", "gravity"),
    [(45.0, 0.0), (0.0, 9.80665)],
    ids=["knuckle share, no weights", "weights, all reciprocating"],
)
def test_a_slave_rod_on_the_crank_pin_is_the_two_mass_slider_crank_at_the_bank_angle(
    knuckle: float, gravity: float
) -> None:
    """With the knuckle radius 0 the slave's gas and inertia loads on the crank pin, its torque and its
    free force are :func:`monitor.model.forces.crank_train_forces`' two-mass slider-crank at the bank
    angle (its crank angle less the bank angle), turned into the master's frame. Weights are compared
    with the rod's whole mass at the piston (each takes a rotating share's weight along its own frame's
    ``-y``). To round-off of the forces' scale."""
    from monitor.model.forces import CrankTrain, crank_kinematics, crank_train_forces

    side = ArticulatedRod(0.2, 0.8, 0.0, 0.0, 0.7, math.radians(60.0))
    angles = np.linspace(0.0, 4 * math.pi, 361)  # two revolutions: a four-stroke's gas cycle
    gas = 4.0e5 * np.exp(-(((angles - math.radians(370.0)) / 0.3) ** 2))
    omega, piston, rod = 50.0, 150.0, 60.0
    share = knuckle / rod  # the rod's centre of gravity from its piston pin over its length
    train = CrankTrain(0.2, 0.2 / 0.7, piston, rod, share, 1.0)
    reference = crank_train_forces(
        crank_kinematics(angles - side.bank_angle, 0.2, 0.2 / 0.7),
        train,
        crank_speed=omega,
        gas_force=gas,
        rod_model="two-mass",
        gravity=gravity,
    )
    forces = side.slave_train_forces(
        angles,
        crank_speed=omega,
        gas_force=gas,
        reciprocating_mass=train.reciprocating_mass,
        knuckle_mass=train.rotating_rod_mass,
        gravity=gravity,
    )
    g = side.bank_angle

    def turned(x: np.ndarray, y: np.ndarray) -> np.ndarray:
        return np.stack([x * math.cos(g) + y * math.sin(g), -x * math.sin(g) + y * math.cos(g)])

    scale = 4.0e5 + (piston + rod) * 0.2 * omega**2
    pin = turned(reference.pin_force_x, reference.pin_force_y)
    np.testing.assert_allclose(forces.loads.pin_force_x, pin[0], rtol=0, atol=1e-9 * scale)
    np.testing.assert_allclose(forces.loads.pin_force_y, pin[1], rtol=0, atol=1e-9 * scale)
    np.testing.assert_allclose(forces.loads.torque, reference.torque, rtol=0, atol=1e-9 * scale * 0.2)
    free = turned(reference.inertia_force_x, reference.inertia_force_y)
    np.testing.assert_allclose(forces.inertia_force_x, free[0], rtol=0, atol=1e-9 * scale)
    np.testing.assert_allclose(forces.inertia_force_y, free[1], rtol=0, atol=1e-9 * scale)
    np.testing.assert_allclose(forces.axial_force, reference.piston_force, rtol=0, atol=1e-9 * scale)


def test_the_slaves_inertia_is_twice_its_kinetic_energy_over_the_speed_squared() -> None:
    """``m_s s'^2 + m_k |K'|^2`` against the places' first derivatives from the 40-digit linkage (1e-9
    of the scale ``(m_s + m_k) R^2``: mpmath's numerical derivative)."""
    piston, knuckle = 120.0, 45.0
    angles = np.linspace(0.0, 2 * math.pi, 12, endpoint=False)
    inertia = ROD.slave_inertia(angles, reciprocating_mass=piston, knuckle_mass=knuckle)
    expected = []
    for a in angles:
        ds, dk = _linkage_derivatives(ROD, float(a), 1)
        expected.append(piston * ds**2 + knuckle * float(dk @ dk))
    scale = (piston + knuckle) * ROD.crank_radius**2
    np.testing.assert_allclose(inertia, expected, rtol=0, atol=1e-9 * scale)
