"""The true engine of a case: its parameters and how a seed draws them (the engine stream)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import Literal

import numpy as np
import numpy.typing as npt

from validation.simulator.linkage import Linkage, slave_dead_centres
from validation.simulator.shared import ENGINE_STREAM, FloatArray


@dataclass(frozen=True)
class DoubleWiebe:
    """Heat release as two Wiebe functions: a premixed and a diffusion phase.

    Attributes
    ----------
    start : float
        Start of the premixed phase, from firing TDC [rad].
    premixed_fraction : float
        Share of the heat released in the premixed phase [-].
    premixed_duration, diffusion_duration : float
        Durations of the phases [rad].
    premixed_shape, diffusion_shape : float
        Wiebe shape exponents m [-].
    diffusion_delay : float
        Start of the diffusion phase after ``start`` [rad].
    a : float
        Wiebe efficiency parameter (6.9: 99.9 % burned at the end of a phase) [-].
    """

    start: float
    premixed_fraction: float
    premixed_duration: float
    premixed_shape: float
    diffusion_delay: float
    diffusion_duration: float
    diffusion_shape: float
    a: float = 6.9

    @property
    def end(self) -> float:
        """End of combustion, from firing TDC [rad]."""
        return max(
            self.start + self.premixed_duration,
            self.start + self.diffusion_delay + self.diffusion_duration,
        )


@dataclass(frozen=True)
class SimEngine:
    """The true engine of a case (SI units throughout).

    Attributes
    ----------
    seed : int
        The case seed it was drawn from.
    ident : str
        Engine id, unique per seed (``^[a-z0-9][a-z0-9._-]*$``).
    engine_class : str
        "slow two-stroke", "medium-speed four-stroke", "high-speed four-stroke" or "small two-stroke".
    cycle_revolutions : int
        1 (two-stroke) or 2 (four-stroke).
    firing_order : tuple of int
        Cylinders (1-based, numbered from the free end) in firing order, cylinder 1 first.
    bore, crank_radius, rod_length : float
        [m].
    rod_cg_from_pin : float
        Rod centre of gravity from the piston (crosshead) pin [m].
    cylinder_pitch : float
        [m].
    bearing_positions : ndarray
        True axial positions of the n + 1 main bearings from bearing 1 [m].
    piston_mass, rod_mass : float
        Piston assembly (with rod and crosshead on a crosshead engine), connecting rod [kg].
    rod_inertia : float
        Rod's moment of inertia about its centre of gravity [kg m^2].
    crank_unbalance, counterweight : float
        Mass times radius of crank pin and webs, and of the counterweights [kg m].
    throw_inertia, flywheel_inertia, driven_inertia : float
        Rotating inertia of one throw, of the flywheel, of the rigidly coupled driven machine [kg m^2].
    compression_ratio : float
        Geometric [-].
    inlet_closing, exhaust_opening, blowdown : float
        Start and end of the closed cycle from firing TDC, and the blowdown duration [rad].
    combustion : DoubleWiebe
    rated_speed : float
        [rad/s].
    rated_imep : float
        Indicated mean effective pressure at rated load [Pa].
    rated_charge_pressure : float
        Absolute charge (scavenge) air pressure at rated load [Pa].
    charge_temperature, wall_temperature : float
        Charge temperature at inlet closing, mean combustion-chamber wall temperature [K].
    friction_mep : float
        Friction mean effective pressure [Pa].
    load_type : str
        "propeller" (torque proportional to speed squared) or "generator" (governed, constant torque).
    peak_pressure_scatter : float
        Cycle-to-cycle standard deviation of a cylinder's peak pressure, relative [-].
    bank_angle : float
        Angle between a V engine's banks' axes [rad]; 0 for an in-line engine.
    leading_bank : str
        "A" or "B": the bank whose axis the crank pin passes first (a V engine).
    rods : str
        "in-line", or on a V "side-by-side", "fork-and-blade" or "articulated" (the leading bank's
        rods are masters, the trailing bank's slave rods hang on their knuckle pins).
    bank_offset : float
        How much further along the shaft the B bank's cylinders stand than the A bank's [m]
        (side-by-side rods; 0 otherwise).
    knuckle_radius, knuckle_angle : float
        Articulated rods: the knuckle pin's distance from the crank pin's centre [m] and its angle
        from the master rod's axis towards the slave bank [rad] (0 otherwise).
    slave_rod_length, slave_rod_cg_from_pin : float
        Articulated rods: knuckle pin to slave piston pin, and the slave rod's centre of gravity from
        its piston pin [m].
    slave_rod_mass, slave_rod_inertia : float
        Articulated rods: [kg], and about its centre of gravity [kg m^2].

    Notes
    -----
    On a V engine of ``n = 2 m`` cylinders, cylinder indices run ``A1..Am`` then ``B1..Bm``
    (``firing_order`` holds those 1-based indices; :attr:`cylinder_names` their names), and ``Ak``
    and ``Bk`` share throw ``k``. In the engine's frame (``y`` up the V's bisector, ``x`` across
    it, towards where the crank pin goes just after passing ``y``) the leading bank's axis leans
    ``-g/2`` and the trailing one's ``+g/2``, so the trailing cylinder of a throw reaches its
    top dead centre a crank angle ``g`` after its partner. ``crank_unbalance``,
    ``counterweight`` and ``throw_inertia`` are per throw.
    """

    seed: int
    ident: str
    engine_class: str
    cycle_revolutions: int
    firing_order: tuple[int, ...]
    bore: float
    crank_radius: float
    rod_length: float
    rod_cg_from_pin: float
    cylinder_pitch: float
    bearing_positions: FloatArray
    piston_mass: float
    rod_mass: float
    rod_inertia: float
    crank_unbalance: float
    counterweight: float
    throw_inertia: float
    flywheel_inertia: float
    driven_inertia: float
    compression_ratio: float
    inlet_closing: float
    exhaust_opening: float
    blowdown: float
    combustion: DoubleWiebe
    rated_speed: float
    rated_imep: float
    rated_charge_pressure: float
    charge_temperature: float
    wall_temperature: float
    friction_mep: float
    load_type: Literal["propeller", "generator"]
    peak_pressure_scatter: float
    bank_angle: float = 0.0
    leading_bank: Literal["A", "B"] = "A"
    rods: Literal["in-line", "side-by-side", "fork-and-blade", "articulated"] = "in-line"
    bank_offset: float = 0.0
    knuckle_radius: float = 0.0
    knuckle_angle: float = 0.0
    slave_rod_length: float = 0.0
    slave_rod_cg_from_pin: float = 0.0
    slave_rod_mass: float = 0.0
    slave_rod_inertia: float = 0.0

    @property
    def cylinders(self) -> int:
        """Number of cylinders."""
        return len(self.firing_order)

    @property
    def is_vee(self) -> bool:
        """Whether the engine has two banks (a V)."""
        return self.bank_angle > 0

    @property
    def throws(self) -> int:
        """Number of crank throws: one per cylinder in line, one per pair of cylinders on a V."""
        return self.cylinders // 2 if self.is_vee else self.cylinders

    @property
    def cylinder_throws(self) -> list[int]:
        """Each cylinder's throw (1-based), by cylinder index."""
        return [c % self.throws + 1 for c in range(self.cylinders)]

    @property
    def cylinder_names(self) -> list[str]:
        """Each cylinder's name by index: "1".."n" in line, "A1".."Am", "B1".."Bm" on a V."""
        if not self.is_vee:
            return [str(c) for c in range(1, self.cylinders + 1)]
        m = self.throws
        return [f"A{k}" for k in range(1, m + 1)] + [f"B{k}" for k in range(1, m + 1)]

    @property
    def cylinder_leans(self) -> FloatArray:
        """Each cylinder's axis from the engine's vertical, towards ``+x`` [rad] (0 in line)."""
        if not self.is_vee:
            return np.zeros(self.cylinders)
        m = self.throws
        a_leads = self.leading_bank == "A"
        half = self.bank_angle / 2
        return np.r_[np.full(m, -half if a_leads else half), np.full(m, half if a_leads else -half)]

    @property
    def linkage(self) -> Linkage:
        """The articulated rods of each throw (:mod:`validation.simulator.linkage`)."""
        if self.rods != "articulated":
            raise ValueError(f"engine {self.ident} has {self.rods} rods: expected articulated ones")
        return Linkage(
            crank_radius=self.crank_radius,
            rod_length=self.rod_length,
            rod_cg_from_pin=self.rod_cg_from_pin,
            knuckle_radius=self.knuckle_radius,
            knuckle_angle=self.knuckle_angle,
            slave_rod_length=self.slave_rod_length,
            slave_rod_cg_from_pin=self.slave_rod_cg_from_pin,
            bank_angle=self.bank_angle,
            piston_mass=self.piston_mass,
            rod_mass=self.rod_mass,
            rod_inertia=self.rod_inertia,
            slave_rod_mass=self.slave_rod_mass,
            slave_rod_inertia=self.slave_rod_inertia,
        )

    @cached_property
    def trailing_offset(self) -> float:
        """Crank angle from a throw's leading cylinder's TDC to its trailing one's [rad].

        The bank angle, but an articulated slave's top dead centre (the linkage solved numerically).
        """
        if self.rods == "articulated":
            return slave_dead_centres(self.linkage)[0]
        return self.bank_angle

    @property
    def slaves(self) -> npt.NDArray[np.bool_]:
        """Which cylinders (by index) are articulated slaves: the trailing bank's, on articulated rods."""
        return np.asarray((self.cylinder_leans > 0) & (self.rods == "articulated"))

    @property
    def unbalance_share(self) -> float:
        """Share of a throw's unbalance each of its cylinders carries in the force model [-]."""
        return 0.5 if self.is_vee else 1.0

    @property
    def cycle_angle(self) -> float:
        """Crank angle of one working cycle [rad]."""
        return 2 * math.pi * self.cycle_revolutions

    @property
    def piston_area(self) -> float:
        """[m^2]."""
        return math.pi * self.bore**2 / 4

    @property
    def swept_volume(self) -> float:
        """Of one cylinder [m^3]."""
        return self.piston_area * 2 * self.crank_radius

    @property
    def clearance_volume(self) -> float:
        """[m^3]."""
        return self.swept_volume / (self.compression_ratio - 1)

    @property
    def firing_angles(self) -> FloatArray:
        """Angle of cylinder 1's crank at which each cylinder (index c - 1) fires [rad]."""
        if self.is_vee:
            return _vee_angles(self)
        angles = np.empty(self.cylinders)
        step = self.cycle_angle / self.cylinders
        for position, cylinder in enumerate(self.firing_order):
            angles[cylinder - 1] = position * step
        return angles

    @property
    def cylinder_positions(self) -> FloatArray:
        """True axial position of each cylinder from bearing 1 [m]: mid-bay of the nominal pitch.

        On a V the A bank's cylinder stands half the bank offset before its throw's mid-bay, the B
        bank's half after it.
        """
        if not self.is_vee:
            return np.asarray(self.cylinder_pitch * (np.arange(self.cylinders, dtype=np.float64) + 0.5))
        mid = self.cylinder_pitch * (np.asarray(self.cylinder_throws, dtype=np.float64) - 0.5)
        m = self.throws
        return np.asarray(mid + np.r_[np.full(m, -0.5), np.full(m, 0.5)] * self.bank_offset)

    @property
    def throw_bearings(self) -> list[tuple[int, int]]:
        """The main bearings (1-based) each cylinder's throw sits between, by cylinder index."""
        return [(k, k + 1) for k in self.cylinder_throws]

    @property
    def bearing_count(self) -> int:
        """Number of main bearings."""
        return self.throws + 1

    @property
    def rigid_inertia(self) -> float:
        """Constant part of the crank's inertia: throws, flywheel, driven machine [kg m^2]."""
        return self.throws * self.throw_inertia + self.flywheel_inertia + self.driven_inertia

    @property
    def friction_torque(self) -> float:
        """Mean friction torque [N m] (friction mep over one cycle of all cylinders)."""
        return self.friction_mep * self.swept_volume * self.cylinders / self.cycle_angle

    @property
    def rated_indicated_torque(self) -> float:
        """Mean indicated torque at rated load [N m]."""
        return self.rated_imep * self.swept_volume * self.cylinders / self.cycle_angle


def _vee_angles(engine: SimEngine) -> FloatArray:
    """A V engine's firing angles: each bank an in-line engine, the trailing cylinder g after its partner.

    The leading bank fires in the order its cylinders take in ``firing_order``, evenly over the
    cycle from its first cylinder's firing; the trailing bank's cylinder of each throw fires the bank
    angle later (an articulated slave at its own TDC, :attr:`SimEngine.trailing_offset`); the whole is
    shifted so that A1 fires at 0 [rad].
    """
    m = engine.throws
    lead = 0 if engine.leading_bank == "A" else m
    bank = [c - 1 - lead for c in engine.firing_order if lead <= c - 1 < lead + m]
    step = engine.cycle_angle / m
    angles = np.empty(engine.cylinders)
    for position, k in enumerate(bank):
        angles[lead + k] = position * step
        angles[(m - lead) + k] = position * step + engine.trailing_offset
    return np.asarray(np.mod(angles - angles[0], engine.cycle_angle))


_FIRING_ORDERS: dict[tuple[int, int], tuple[tuple[int, ...], ...]] = {
    # four-stroke, in-line (usual orders; the 10- and 11-cylinder ones are plausible permutations)
    (2, 1): ((1,),),
    (2, 2): ((1, 2),),
    (2, 3): ((1, 3, 2), (1, 2, 3)),
    (2, 4): ((1, 3, 4, 2), (1, 2, 4, 3)),
    (2, 5): ((1, 2, 4, 5, 3), (1, 3, 5, 4, 2)),
    (2, 6): ((1, 5, 3, 6, 2, 4), (1, 4, 2, 6, 3, 5)),
    (2, 7): ((1, 2, 4, 6, 7, 5, 3), (1, 3, 5, 7, 6, 4, 2)),
    (2, 8): ((1, 6, 2, 5, 8, 3, 7, 4), (1, 4, 7, 6, 8, 5, 2, 3)),
    (2, 9): ((1, 7, 4, 2, 8, 6, 3, 9, 5), (1, 6, 3, 2, 8, 7, 4, 9, 5)),
    (2, 10): ((1, 6, 3, 8, 5, 10, 4, 9, 2, 7),),
    (2, 11): ((1, 4, 9, 6, 2, 10, 7, 3, 11, 5, 8),),
    (2, 12): ((1, 7, 5, 11, 3, 9, 6, 12, 2, 8, 4, 10), (1, 12, 5, 8, 3, 10, 6, 7, 2, 11, 4, 9)),
    # two-stroke
    (1, 1): ((1,),),
    (1, 2): ((1, 2),),
    (1, 3): ((1, 3, 2), (1, 2, 3)),
    (1, 4): ((1, 4, 3, 2), (1, 3, 2, 4)),
    (1, 5): ((1, 4, 3, 2, 5), (1, 5, 2, 3, 4)),
    (1, 6): ((1, 5, 3, 4, 2, 6), (1, 6, 2, 4, 3, 5)),
    (1, 7): ((1, 7, 2, 5, 4, 3, 6),),
    (1, 8): ((1, 8, 3, 4, 7, 2, 5, 6),),
    (1, 9): ((1, 6, 7, 3, 5, 8, 2, 4, 9),),
    (1, 10): ((1, 8, 7, 3, 5, 10, 2, 6, 4, 9),),
    (1, 11): ((1, 8, 11, 4, 5, 9, 2, 7, 10, 3, 6),),
    (1, 12): ((1, 8, 11, 4, 5, 9, 2, 7, 12, 3, 6, 10),),
}


def _uniform(rng: np.random.Generator, low: float, high: float) -> float:
    return float(rng.uniform(low, high))


def _log_uniform(rng: np.random.Generator, low: float, high: float) -> float:
    return float(math.exp(rng.uniform(math.log(low), math.log(high))))


@dataclass(frozen=True)
class _ClassDraw:
    """What an engine class draws first: speed, cylinders, proportions, pressures, timing, combustion."""

    rpm: float
    cylinders: int
    piston_speed: float
    stroke_bore: float
    rod_ratio: float
    revs: int
    crosshead: bool
    imep: float
    charge: float
    compression: float
    friction: float
    ivc: float
    evo: float
    blowdown: float
    law: DoubleWiebe


def _slow_two_stroke(rng: np.random.Generator) -> _ClassDraw:
    """A slow two-stroke crosshead engine, 60-200 rpm (the draws in the engine stream's order)."""
    deg = math.pi / 180
    rpm = _log_uniform(rng, 60.0, 200.0)
    cylinders = int(rng.integers(4, 13))
    piston_speed, stroke_bore = _uniform(rng, 6.5, 9.0), _uniform(rng, 3.2, 4.4)
    rod_ratio = _uniform(rng, 0.40, 0.48)
    imep, charge = _uniform(rng, 17e5, 21e5), _uniform(rng, 3.2e5, 4.0e5)
    compression = _uniform(rng, 17.0, 21.0)
    friction = _uniform(rng, 0.6e5, 1.0e5)
    ivc, evo, blowdown = -_uniform(rng, 100, 120), _uniform(rng, 105, 120), _uniform(rng, 30, 45)
    law = DoubleWiebe(
        start=_uniform(rng, -5, 0) * deg,
        premixed_fraction=_uniform(rng, 0.05, 0.15),
        premixed_duration=_uniform(rng, 6, 10) * deg,
        premixed_shape=_uniform(rng, 1.5, 2.5),
        diffusion_delay=_uniform(rng, 2, 5) * deg,
        diffusion_duration=_uniform(rng, 45, 70) * deg,
        diffusion_shape=_uniform(rng, 0.7, 1.2),
    )
    return _ClassDraw(
        rpm,
        cylinders,
        piston_speed,
        stroke_bore,
        rod_ratio,
        1,
        True,
        imep,
        charge,
        compression,
        friction,
        ivc,
        evo,
        blowdown,
        law,
    )


def _small_two_stroke(rng: np.random.Generator) -> _ClassDraw:
    """A small two-stroke trunk-piston engine, 300-1000 rpm (the draws in the engine stream's order)."""
    deg = math.pi / 180
    rpm = _uniform(rng, 300.0, 1000.0)
    cylinders = int(rng.integers(1, 5))
    piston_speed, stroke_bore = _uniform(rng, 4.0, 7.0), _uniform(rng, 1.1, 2.0)
    rod_ratio = _uniform(rng, 0.22, 0.30)
    imep, charge = _uniform(rng, 4e5, 7e5), _uniform(rng, 1.05e5, 1.2e5)
    compression = _uniform(rng, 6.0, 9.0)
    friction = _uniform(rng, 0.4e5, 0.8e5)
    ivc, evo, blowdown = -_uniform(rng, 100, 115), _uniform(rng, 95, 110), _uniform(rng, 30, 40)
    law = DoubleWiebe(
        start=_uniform(rng, -18, -8) * deg,
        premixed_fraction=_uniform(rng, 0.2, 0.5),
        premixed_duration=_uniform(rng, 10, 20) * deg,
        premixed_shape=_uniform(rng, 1.5, 2.5),
        diffusion_delay=_uniform(rng, 4, 8) * deg,
        diffusion_duration=_uniform(rng, 40, 60) * deg,
        diffusion_shape=_uniform(rng, 1.0, 2.0),
    )
    return _ClassDraw(
        rpm,
        cylinders,
        piston_speed,
        stroke_bore,
        rod_ratio,
        1,
        False,
        imep,
        charge,
        compression,
        friction,
        ivc,
        evo,
        blowdown,
        law,
    )


def _four_stroke(rng: np.random.Generator, *, medium: bool) -> _ClassDraw:
    """A medium-speed (300-1000 rpm) or high-speed (1000-1500 rpm) four-stroke (the stream's order)."""
    deg = math.pi / 180
    if medium:
        rpm = _log_uniform(rng, 300.0, 1000.0)
        counts = [4, 5, 6, 7, 8, 9, 10, 12]
        cylinders = int(rng.choice(counts, p=[0.08, 0.08, 0.3, 0.08, 0.16, 0.14, 0.06, 0.1]))
        piston_speed, stroke_bore = _uniform(rng, 8.0, 10.5), _uniform(rng, 1.15, 1.45)
        rod_ratio = _uniform(rng, 0.22, 0.30)
        imep, charge = _uniform(rng, 20e5, 27e5), _uniform(rng, 3.0e5, 4.5e5)
        compression = _uniform(rng, 12.5, 15.0)
        friction = _uniform(rng, 0.9e5, 1.4e5)
    else:
        rpm = _log_uniform(rng, 1000.0, 1500.0)
        cylinders = int(rng.choice(np.arange(1, 13), p=np.array([3, 2, 2, 3, 1, 3, 1, 2, 1, 1, 1, 2]) / 22))
        piston_speed, stroke_bore = _uniform(rng, 9.0, 11.5), _uniform(rng, 1.05, 1.3)
        rod_ratio = _uniform(rng, 0.24, 0.32)
        imep, charge = _uniform(rng, 16e5, 24e5), _uniform(rng, 2.2e5, 3.5e5)
        compression = _uniform(rng, 14.0, 17.0)
        friction = _uniform(rng, 1.0e5, 1.6e5)
    ivc, evo, blowdown = -_uniform(rng, 200, 220), _uniform(rng, 120, 140), _uniform(rng, 40, 55)
    law = DoubleWiebe(
        start=_uniform(rng, -8, -2) * deg,
        premixed_fraction=_uniform(rng, 0.05, 0.3),
        premixed_duration=_uniform(rng, 5, 12) * deg,
        premixed_shape=_uniform(rng, 1.5, 3.0),
        diffusion_delay=_uniform(rng, 3, 6) * deg,
        diffusion_duration=_uniform(rng, 40, 70) * deg,
        diffusion_shape=_uniform(rng, 0.6, 1.2),
    )
    return _ClassDraw(
        rpm,
        cylinders,
        piston_speed,
        stroke_bore,
        rod_ratio,
        2,
        False,
        imep,
        charge,
        compression,
        friction,
        ivc,
        evo,
        blowdown,
        law,
    )


def random_engine(seed: int) -> SimEngine:
    """Draw the true engine of a case.

    Parameters
    ----------
    seed : int
        The case seed, >= 0 (the engine comes from its own random stream of that seed).

    Returns
    -------
    SimEngine

    Notes
    -----
    Stroke ``S = c_m 30 / n`` from a mean piston speed ``c_m`` [m/s] and the rated speed ``n``
    [rpm], bore from a stroke-to-bore ratio typical of the class; piston assembly mass
    ``k_p D^3`` (``k_p`` about 6300 kg/m^3 for a crosshead engine with piston rod and
    crosshead, 3000 for a trunk piston), rod 1.0-1.5 times that; throw inertia
    ``(1.5-2.5) (m_p + m_r) R^2``; total rigid inertia ``J = dE / (delta omega^2)`` with an
    estimated energy fluctuation ``dE`` per cycle and a cyclic irregularity ``delta`` of the drive.
    """
    if seed < 0:
        raise ValueError(f"seed = {seed}: expected an integer >= 0")
    rng = np.random.default_rng(np.random.SeedSequence([seed, ENGINE_STREAM]))
    classes = ("slow two-stroke", "medium-speed four-stroke", "high-speed four-stroke", "small two-stroke")
    engine_class = classes[int(rng.choice(4, p=[0.3, 0.35, 0.25, 0.1]))]
    if engine_class == "slow two-stroke":
        drawn = _slow_two_stroke(rng)
    elif engine_class == "small two-stroke":
        drawn = _small_two_stroke(rng)
    else:
        drawn = _four_stroke(rng, medium=engine_class == "medium-speed four-stroke")
    deg = math.pi / 180
    stroke = min(drawn.piston_speed * 30.0 / drawn.rpm, 3.6)
    bore = stroke / drawn.stroke_bore
    radius = stroke / 2
    rod_length = radius / drawn.rod_ratio
    density = _uniform(rng, 5500, 7000) if drawn.crosshead else _uniform(rng, 2500, 3500)
    piston = density * bore**3
    rod = piston * (_uniform(rng, 1.1, 1.5) if drawn.crosshead else _uniform(rng, 1.0, 1.3))
    cg = rod_length * _uniform(rng, 0.55, 0.70)
    rod_inertia = rod * (rod_length * _uniform(rng, 0.26, 0.33)) ** 2
    crank_unbalance = _uniform(rng, 0.6, 1.0) * rod * radius
    counterweight = _uniform(rng, 0.4, 1.1) * crank_unbalance
    throw = _uniform(rng, 1.5, 2.5) * (piston + rod) * radius**2
    order_choices = _FIRING_ORDERS[(drawn.revs, drawn.cylinders)]
    firing_order = order_choices[int(rng.integers(len(order_choices)))]
    load_type: Literal["propeller", "generator"]
    if engine_class == "slow two-stroke":
        load_type = "propeller"
    else:
        load_type = "propeller" if rng.random() < 0.5 else "generator"
    irregularity = 1 / _uniform(rng, 150, 300) if load_type == "generator" else 1 / _uniform(rng, 70, 150)
    omega = drawn.rpm * math.pi / 30
    work = drawn.imep * math.pi * bore**2 / 4 * stroke
    fluctuation = work * (1.3 if drawn.cylinders == 1 else 0.8 if drawn.cylinders == 2 else 0.35)
    recip_mean = drawn.cylinders * (piston + 0.5 * rod) * radius**2 * 0.5
    rest = fluctuation / (irregularity * omega**2) - drawn.cylinders * throw - recip_mean
    rest = max(rest, 0.3 * drawn.cylinders * throw)
    flywheel_share = _uniform(rng, 0.4, 0.8)
    pitch = bore * _uniform(rng, 1.6, 1.9)
    bearings = pitch * (np.arange(drawn.cylinders + 1) + rng.uniform(-0.02, 0.02, drawn.cylinders + 1))
    bearings -= bearings[0]
    return SimEngine(
        seed=seed,
        ident=f"val-{seed:06d}-{drawn.cylinders}cyl-{'2s' if drawn.revs == 1 else '4s'}",
        engine_class=engine_class,
        cycle_revolutions=drawn.revs,
        firing_order=tuple(int(c) for c in firing_order),
        bore=bore,
        crank_radius=radius,
        rod_length=rod_length,
        rod_cg_from_pin=cg,
        cylinder_pitch=pitch,
        bearing_positions=bearings,
        piston_mass=piston,
        rod_mass=rod,
        rod_inertia=rod_inertia,
        crank_unbalance=crank_unbalance,
        counterweight=counterweight,
        throw_inertia=throw,
        flywheel_inertia=flywheel_share * rest,
        driven_inertia=(1 - flywheel_share) * rest,
        compression_ratio=drawn.compression,
        inlet_closing=drawn.ivc * deg,
        exhaust_opening=drawn.evo * deg,
        blowdown=drawn.blowdown * deg,
        combustion=drawn.law,
        rated_speed=omega,
        rated_imep=drawn.imep,
        rated_charge_pressure=drawn.charge,
        charge_temperature=_uniform(rng, 320, 350) + (10.0 if drawn.revs == 1 else 0.0),
        wall_temperature=_uniform(rng, 450, 550),
        friction_mep=drawn.friction,
        load_type=load_type,
        peak_pressure_scatter=_uniform(rng, 0.01, 0.02),
    )
