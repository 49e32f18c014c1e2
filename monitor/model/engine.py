"""Engine descriptions: what the physics needs to know about an engine.

An engine is described in a TOML file (``recordings/engines/*.toml``) whose
fields carry their unit in the name (``bore_m``, ``rated_speed_rpm``,
``rated_imep_bar``); :func:`load_engine` validates it into an immutable
:class:`Engine` whose properties give the SI values the model uses
(``crank_radius`` [m], ``rated_speed`` [rad/s], ``firing_angles`` [rad]).

Conventions.  Cylinders are numbered 1..n from the free end unless
``cylinder_numbering`` says otherwise.  The firing angle of cylinder ``c`` is
the crank angle of cylinder 1's crank (from its firing TDC) at which cylinder
``c`` reaches its own firing TDC; cylinder ``c``'s crank therefore trails
cylinder 1's by that angle, and its local crank angle is
``alpha - firing_angle[c]``.  An evenly firing engine needs only its firing
order; uneven firing gives the angles explicitly.  Crank throw ``c`` sits
between two main bearings (by default ``c`` and ``c + 1``) and its forces are
shared between them by the lever rule (see :mod:`monitor.model.crankshaft`).

A description that breaks a rule is refused with
:class:`~monitor.errors.EngineDescriptionError` naming the field, the value
and the rule.
"""

from __future__ import annotations

import difflib
import math
import tomllib
from functools import cached_property
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import (
    AfterValidator,
    BaseModel,
    ConfigDict,
    Field,
    ValidationError,
    model_validator,
)

from monitor.errors import EngineDescriptionError, ModelError
from monitor.model.articulated import ArticulatedRod
from monitor.model.banks import (
    Vee,
    articulated_rod,
    bank_axes,
    cylinder_banks,
    cylinder_names,
    cylinder_throws,
    vee_crank_angles,
)
from monitor.model.quantities import (
    AngleDeg,
    Inertia,
    Length,
    Mass,
    PressureBar,
    Unbalance,
    between,
    positive,
)
from monitor.model.shaft_description import CrankAxial, ShaftElement, ShaftLine
from monitor.types import FloatArray

__all__ = [
    "Bearings",
    "ChargePressureLaw",
    "Combustion",
    "CrankAxial",
    "Engine",
    "Firing",
    "Geometry",
    "Masses",
    "Operation",
    "PressureTrace",
    "SensorTransfer",
    "ShaftElement",
    "ShaftLine",
    "Vee",
    "VibrationLimits",
    "bundled_engines",
    "load_engine",
    "parse_engine",
]

BUNDLED_DIR = Path(__file__).resolve().parent / "engines"  # package data; recordings/engines links here


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, strict=False)


class Geometry(_Strict):
    """Cylinder and crank-train geometry."""

    bore_m: Annotated[float, AfterValidator(between(0.01, 1.5, "m", "was it given in mm?"))]
    stroke_m: Annotated[float, AfterValidator(between(0.01, 4.0, "m", "was it given in mm?"))]
    rod_length_m: Length | None = None
    rod_ratio: float | None = Field(
        default=None, description="crank radius / rod length; give this or rod_length_m"
    )
    cylinder_pitch_m: Length | None = None

    @model_validator(mode="after")
    def _rod(self) -> Geometry:
        if (self.rod_length_m is None) == (self.rod_ratio is None):
            raise ValueError(
                "give exactly one of rod_length_m (pin centre to pin centre) or rod_ratio "
                "(crank radius / rod length)"
            )
        ratio = self.rod_ratio if self.rod_ratio is not None else self.stroke_m / 2 / self.rod_length_m  # type: ignore[operator]
        if not 0 < ratio < 1:
            field = "rod_ratio" if self.rod_ratio is not None else "rod_length_m"
            value = self.rod_ratio if self.rod_ratio is not None else self.rod_length_m
            raise ValueError(
                f"{field} = {value!r} gives rod ratio {ratio:.6g}: expected 0 < crank radius / "
                "rod length < 1 (the rod must be longer than the crank radius)"
            )
        return self


class Masses(_Strict):
    """Masses of the crank train of one cylinder."""

    piston_assembly_kg: Mass = Field(
        description="piston with rings and pin; on a crosshead engine also piston rod and crosshead"
    )
    conrod_kg: Mass
    conrod_cg_from_piston_pin_m: Length = Field(
        description="distance of the rod's centre of gravity from the piston (crosshead) pin centre"
    )
    conrod_inertia_kgm2: Inertia = Field(description="moment of inertia about the centre of gravity")
    crank_unbalance_kgm: Unbalance = Field(
        default=0.0, description="crank pin and webs: mass times radius, towards the crank pin"
    )
    counterweight_kgm: Unbalance = Field(
        default=0.0, description="counterweights: mass times radius, opposite the crank pin"
    )


class Firing(_Strict):
    """Firing order and, for uneven firing, the firing angles."""

    order: list[int] | list[str] = Field(
        description="cylinders by number (in line) or by name (a V engine's A1, B1, ...), first to fire first"
    )
    angles_deg: list[float] | None = Field(
        default=None,
        description="firing angle of each cylinder (A1..Am, B1..Bm on a V) after cylinder 1 (A1) [deg]",
    )


class Operation(_Strict):
    """Rated operating point."""

    rated_speed_rpm: Annotated[float, AfterValidator(between(1.0, 20000.0, "rpm"))]
    rated_power_kw: Annotated[float, AfterValidator(positive("kW"))] | None = None


class Bearings(_Strict):
    """Main bearings and which crank throw sits between which two of them."""

    count: int | None = Field(default=None, description="number of main bearings (default throws + 1)")
    throws: list[tuple[int, int]] | None = Field(
        default=None, description="bearing pair of each crank throw, in throw order (default (k, k + 1))"
    )
    positions_m: list[float] | None = Field(
        default=None, description="axial bearing positions from bearing 1 (default: mid-pitch)"
    )


class SensorTransfer(_Strict):
    """A bearing sensor's transfer from its bearing's force to its orders, given instead of calibrated.

    ``X_k = H_k F_k`` with ``H_k = magnitude_k exp(i phase_k)`` [the sensor's unit per newton], valid at
    ``speed_rpm`` (the structure's response is a function of frequency, ``k`` times the speed); written
    by ``engine-monitor calibrate HEALTHY.h5 -o FILE.toml`` or taken from a structural model.
    """

    channel: str = Field(description="the recording channel it applies to")
    bearing: Annotated[int, Field(ge=1)]
    direction: Literal["vertical", "horizontal"]
    unit: str
    speed_rpm: Annotated[float, AfterValidator(positive("rpm"))]
    orders: list[float] = Field(min_length=1)
    magnitude: list[float] = Field(description="|H_k| [unit per N]")
    phase_deg: list[float] = Field(description="arg H_k [deg]")
    magnitude_error: list[float] | None = Field(default=None, description="standard error of |H_k|")

    @model_validator(mode="after")
    def _lengths(self) -> SensorTransfer:
        n = len(self.orders)
        for name in ("magnitude", "phase_deg", "magnitude_error"):
            values = getattr(self, name)
            if values is not None and len(values) != n:
                raise ValueError(
                    f"sensor_transfers ({self.channel!r}).{name} has {len(values)} values: expected {n}, "
                    "one per order"
                )
        if any(m < 0 for m in self.magnitude):
            raise ValueError(f"sensor_transfers ({self.channel!r}).magnitude: expected values >= 0")
        return self


class VibrationLimits(_Strict):
    """Overall vibration velocity zones in the style of ISO 10816-6 (see :mod:`monitor.diagnosis.zones`)."""

    zone_boundaries_mm_s: tuple[float, float, float] = Field(
        description="rms velocity at the A/B, B/C and C/D zone boundaries [mm/s], increasing"
    )
    band_hz: tuple[float, float] = Field(default=(2.0, 1000.0), description="band of the rms [Hz]")

    @model_validator(mode="after")
    def _ordered(self) -> VibrationLimits:
        a, b, c = self.zone_boundaries_mm_s
        if not 0 < a < b < c:
            raise ValueError(
                f"vibration_limits.zone_boundaries_mm_s = {list(self.zone_boundaries_mm_s)}: "
                "expected three increasing positive values (A/B, B/C, C/D)"
            )
        low, high = self.band_hz
        if not 0 < low < high:
            raise ValueError(f"vibration_limits.band_hz = {list(self.band_hz)}: expected 0 < low < high")
        return self


#: How the charge pressure at inlet closing follows the load (see :mod:`monitor.model.gas`).
ChargePressureLaw = Literal["turbocharged", "held", "naturally-aspirated"]

#: A naturally aspirated engine's intake_pressure_bar may differ from ambient by this fraction (intake
#: depression at rated flow, ram effect of a tuned intake: a few per cent either way) [-].
NATURAL_INTAKE_TOLERANCE = 0.1


class Combustion(_Strict):
    """Parametric cylinder-pressure model (used when no pressure trace is measured).

    Closed cycle between inlet closing and exhaust opening: polytropic
    compression, then heat release by a Wiebe law with polytropic expansion;
    the heat released is scaled so that the indicated mean effective
    pressure is ``load * rated_imep_bar``.  The charge pressure at inlet
    closing follows the load by ``charge_pressure_law``; a description that
    does not state it gets ``"turbocharged"``. See :mod:`monitor.model.gas`.
    """

    rated_imep_bar: Annotated[float, AfterValidator(between(1.0, 60.0, "bar"))]
    compression_ratio: Annotated[float, AfterValidator(between(4.0, 40.0, "-"))]
    intake_pressure_bar: PressureBar = Field(
        description="charge (scavenge) air pressure, absolute, at rated load"
    )
    ambient_pressure_bar: PressureBar = 1.013
    charge_pressure_law: ChargePressureLaw = Field(
        default="turbocharged",
        description=(
            "how the charge pressure follows the load: 'turbocharged' (from ambient at no load to "
            "intake_pressure_bar at rated, linear in load), 'held' (intake_pressure_bar at every load) "
            "or 'naturally-aspirated' (ambient at every load)"
        ),
    )
    inlet_closing_deg: AngleDeg = Field(description="start of compression, before firing TDC (< 0)")
    exhaust_opening_deg: AngleDeg = Field(description="end of expansion, after firing TDC (> 0)")
    blowdown_deg: Annotated[float, AfterValidator(between(1.0, 120.0, "deg"))] = 40.0
    combustion_start_deg: AngleDeg = 0.0
    combustion_duration_deg: Annotated[float, AfterValidator(between(5.0, 180.0, "deg"))] = 60.0
    wiebe_a: Annotated[float, AfterValidator(between(1.0, 12.0, "-"))] = 6.9
    wiebe_m: Annotated[float, AfterValidator(between(0.0, 5.0, "-"))] = 1.0
    polytropic_compression: Annotated[float, AfterValidator(between(1.0, 1.45, "-"))] = 1.36
    polytropic_expansion: Annotated[float, AfterValidator(between(1.0, 1.45, "-"))] = 1.30

    @model_validator(mode="after")
    def _timing(self) -> Combustion:
        if not self.inlet_closing_deg < self.combustion_start_deg < self.exhaust_opening_deg:
            raise ValueError(
                f"expected inlet_closing_deg ({self.inlet_closing_deg:g}) < combustion_start_deg "
                f"({self.combustion_start_deg:g}) < exhaust_opening_deg ({self.exhaust_opening_deg:g})"
            )
        if not self.inlet_closing_deg < 0 < self.exhaust_opening_deg:
            raise ValueError("expected inlet_closing_deg < 0 < exhaust_opening_deg (degrees from firing TDC)")
        if self.charge_pressure_law == "naturally-aspirated" and not (
            abs(self.intake_pressure_bar - self.ambient_pressure_bar)
            <= NATURAL_INTAKE_TOLERANCE * self.ambient_pressure_bar
        ):
            raise ValueError(
                f"charge_pressure_law = 'naturally-aspirated' with intake_pressure_bar = "
                f"{self.intake_pressure_bar:g}: expected about the ambient {self.ambient_pressure_bar:g} bar "
                f"(within {NATURAL_INTAKE_TOLERANCE:.0%}); a charged engine is 'turbocharged' or 'held'"
            )
        return self


class PressureTrace(_Strict):
    """A measured indicator diagram: cylinder pressure against crank angle from firing TDC."""

    file: str | None = Field(
        default=None, description="CSV with columns crank_angle_deg, pressure_bar (relative path)"
    )
    crank_angle_deg: list[float] | None = None
    pressure_bar: list[float] | None = None
    absolute: bool = Field(default=True, description="pressures are absolute (else gauge)")
    speed_rpm: Annotated[float, AfterValidator(between(1.0, 20000.0, "rpm"))] | None = None
    load: Annotated[float, AfterValidator(between(0.0, 1.2, "-"))] | None = None

    @model_validator(mode="after")
    def _source(self) -> PressureTrace:
        inline = self.crank_angle_deg is not None or self.pressure_bar is not None
        if inline == (self.file is not None):
            raise ValueError("give either file or the crank_angle_deg and pressure_bar arrays")
        if inline and (self.crank_angle_deg is None or self.pressure_bar is None):
            raise ValueError("crank_angle_deg and pressure_bar must both be given")
        return self


class Engine(_Strict):
    """A validated engine description. SI values are properties; fields keep the file's units."""

    id: Annotated[str, Field(pattern=r"^[a-z0-9][a-z0-9._-]*$")]
    name: str
    cycle: Literal["two-stroke", "four-stroke"]
    cylinders: Annotated[int, Field(ge=1, le=24)]
    cylinder_numbering: Literal["from free end", "from flywheel end"] = "from free end"
    notes: str = ""
    geometry: Geometry
    masses: Masses
    firing: Firing
    operation: Operation
    bearings: Bearings = Field(default_factory=Bearings)
    combustion: Combustion | None = None
    pressure_trace: PressureTrace | None = None
    shaft_line: ShaftLine | None = None
    vibration_limits: VibrationLimits | None = None
    sensor_transfers: list[SensorTransfer] = Field(default_factory=list)
    vee: Vee | None = Field(default=None, description="two banks on one crankshaft (monitor.model.banks)")
    source_dir: Path | None = Field(default=None, exclude=True, description="folder of the file")

    @model_validator(mode="after")
    def _consistency(self) -> Engine:
        n = self.cylinders
        if self.vee is not None and n % 2:
            raise ValueError(f"cylinders = {n} on a V engine: expected an even number, half on each bank")
        order = self.firing_order
        if self.firing.angles_deg is not None:
            angles = self.firing.angles_deg
            span = 360.0 * self.cycle_revolutions
            if len(angles) != n:
                raise ValueError(
                    f"firing.angles_deg has {len(angles)} values: expected {n}, one per cylinder"
                )
            if angles[0] != 0.0 or not all(0.0 <= a < span for a in angles):
                raise ValueError(
                    f"firing.angles_deg = {angles}: expected cylinder 1 at 0 and every angle in [0, {span:g})"
                )
            by_angle = [c for _, c in sorted(zip(angles, range(n), strict=True))]
            if by_angle != order:
                listed = [self.cylinder_names[c] if self.vee else c + 1 for c in by_angle]
                raise ValueError(
                    f"firing.angles_deg = {angles} fire the cylinders in the order {listed}, "
                    f"not firing.order = {self.firing.order}"
                )
        if self.vee is not None:
            _ = self.firing_angles  # the bank geometry's check of the angles, given or found
            try:
                _ = self.articulated
            except ModelError as error:
                raise ValueError(f"vee: {error}") from None
        cg = self.masses.conrod_cg_from_piston_pin_m
        if not 0 < cg < self.rod_length:
            raise ValueError(
                f"masses.conrod_cg_from_piston_pin_m = {cg!r}: expected between 0 and the rod "
                f"length {self.rod_length:.6g} m"
            )
        nb = self.bearing_count
        if nb < 2:
            raise ValueError(f"bearings.count = {nb}: expected at least 2 main bearings")
        if self.bearings.throws is not None and len(self.bearings.throws) != self.throws:
            raise ValueError(
                f"bearings.throws has {len(self.bearings.throws)} pairs: expected {self.throws}, one a throw"
            )
        for c, pair in enumerate(self.throw_bearings):
            if not all(1 <= b <= nb for b in pair) or pair[0] == pair[1]:
                raise ValueError(
                    f"bearings.throws: cylinder {self.cylinder_names[c]}'s throw between bearings {pair}: "
                    f"expected two different bearings in 1..{nb}"
                )
        if self.bearings.positions_m is not None and len(self.bearings.positions_m) != nb:
            raise ValueError(
                f"bearings.positions_m has {len(self.bearings.positions_m)} values: expected {nb}"
            )
        for transfer in self.sensor_transfers:
            if transfer.bearing > nb:
                raise ValueError(
                    f"sensor_transfers ({transfer.channel!r}): bearing {transfer.bearing} does not exist "
                    f"(the engine has {nb} main bearings)"
                )
        cycle_model = self.combustion
        if cycle_model is not None:
            end = cycle_model.exhaust_opening_deg + cycle_model.blowdown_deg
            next_closing = cycle_model.inlet_closing_deg + 360 * self.cycle_revolutions
            if end > next_closing:
                raise ValueError(
                    f"combustion.exhaust_opening_deg + blowdown_deg = {end:g} deg reaches past the next "
                    f"inlet closing at {next_closing:g} deg"
                )
        if self.combustion is None and self.pressure_trace is None:
            raise ValueError(
                "no gas-force model: add a [combustion] table (parametric cylinder pressure) or a "
                "[pressure_trace] (measured indicator diagram)"
            )
        return self

    # --- SI values -------------------------------------------------------------------------
    @property
    def cycle_revolutions(self) -> int:
        """Crank revolutions per working cycle: 1 two-stroke, 2 four-stroke."""
        return 1 if self.cycle == "two-stroke" else 2

    @property
    def crank_radius(self) -> float:
        """R = stroke / 2 [m]."""
        return self.geometry.stroke_m / 2

    @property
    def rod_length(self) -> float:
        """Connecting-rod length, pin centre to pin centre [m]."""
        if self.geometry.rod_length_m is not None:
            return self.geometry.rod_length_m
        return self.crank_radius / self.geometry.rod_ratio  # type: ignore[operator]

    @property
    def rod_ratio(self) -> float:
        """lambda = R / L [-]."""
        return self.crank_radius / self.rod_length

    @property
    def piston_area(self) -> float:
        """Piston crown area pi D^2 / 4 [m^2]."""
        return math.pi * self.geometry.bore_m**2 / 4

    @property
    def swept_volume(self) -> float:
        """Swept volume of one cylinder [m^3]."""
        return self.piston_area * self.geometry.stroke_m

    @property
    def rated_speed(self) -> float:
        """Rated crank speed [rad/s]."""
        return self.operation.rated_speed_rpm * math.pi / 30

    @property
    def conrod_cg_fraction(self) -> float:
        """Rod centre of gravity from the piston pin over the rod length [-]."""
        return self.masses.conrod_cg_from_piston_pin_m / self.rod_length

    @property
    def reciprocating_mass(self) -> float:
        """Piston assembly plus the rod's piston-pin share in the two-mass split [kg]."""
        return self.masses.piston_assembly_kg + self.masses.conrod_kg * (1 - self.conrod_cg_fraction)

    @property
    def rotating_rod_mass(self) -> float:
        """The rod's crank-pin share in the two-mass split [kg]."""
        return self.masses.conrod_kg * self.conrod_cg_fraction

    @property
    def net_crank_unbalance(self) -> float:
        """Crank pin and webs minus counterweights, towards the pin [kg m]."""
        return self.masses.crank_unbalance_kgm - self.masses.counterweight_kgm

    @cached_property
    def articulated(self) -> ArticulatedRod | None:
        """The master and slave rods on each throw of a V engine with articulated rods, else None."""
        return articulated_rod(self.vee, self.crank_radius, self.rod_length)

    @cached_property
    def cylinder_names(self) -> list[str]:
        """Each cylinder's name, by index: ``1..n`` in line, ``A1..Am, B1..Bm`` on a V."""
        return cylinder_names(self.cylinders, self.vee)

    @cached_property
    def cylinder_banks(self) -> list[str]:
        """Each cylinder's bank, by index: ``""`` in line, ``"A"`` or ``"B"`` on a V."""
        return cylinder_banks(self.cylinders, self.vee)

    @cached_property
    def firing_order(self) -> list[int]:
        """The firing order as cylinder indices (0-based); ``ValueError`` unless each is in it once."""
        names = self.cylinder_names
        given = [str(c) for c in self.firing.order]
        if sorted(given) != sorted(names):
            half = self.cylinders // 2
            which = f"A1..A{half} and B1..B{half}" if self.vee is not None else f"1..{self.cylinders}"
            raise ValueError(
                f"firing.order = {self.firing.order}: expected a permutation of the cylinders {which}, "
                "each once"
            )
        return [names.index(c) for c in given]

    @cached_property
    def firing_angles(self) -> FloatArray:
        """Firing angle of each cylinder (by index) after cylinder 1's TDC [rad]."""
        given = self.firing.angles_deg
        if self.vee is not None:  # from A1's own TDC, in the order of the cylinders' own TDCs
            return vee_crank_angles(
                self.firing_order, self.vee, self.articulated, self.cycle_revolutions, given
            )
        if given is not None:
            return np.radians(np.asarray(given, dtype=np.float64))
        order = self.firing_order
        start = order.index(0)
        rotated = order[start:] + order[:start]
        angles = np.empty(self.cylinders)
        step = 2 * np.pi * self.cycle_revolutions / self.cylinders
        for position, cylinder in enumerate(rotated):
            angles[cylinder] = position * step
        return angles

    @cached_property
    def cylinder_axes(self) -> FloatArray:
        """Each cylinder's axis from the engine's vertical, towards ``+x`` [rad] (0 in line)."""
        return bank_axes(self.cylinders, self.vee)

    @property
    def throws(self) -> int:
        """Number of crank throws: one per cylinder in line, one per pair on a V."""
        return self.cylinders if self.vee is None else self.cylinders // 2

    @cached_property
    def cylinder_throw(self) -> list[int]:
        """Each cylinder's crank throw (0-based, from cylinder 1's end), by cylinder index."""
        return cylinder_throws(self.cylinders, self.vee)

    @property
    def bearing_count(self) -> int:
        """Number of main bearings."""
        return self.bearings.count if self.bearings.count is not None else self.throws + 1

    @property
    def throw_bearings(self) -> list[tuple[int, int]]:
        """The two main bearings (1-based) each cylinder's throw sits between, by cylinder index."""
        if self.bearings.throws is not None:
            pairs = [tuple(p) for p in self.bearings.throws]
        else:
            pairs = [(k, k + 1) for k in range(1, self.throws + 1)]
        return [pairs[k] for k in self.cylinder_throw]  # type: ignore[misc]

    @property
    def cylinder_positions(self) -> FloatArray:
        """Axial position of each cylinder from cylinder 1 (A1), in numbering direction [m]."""
        pitch = self.geometry.cylinder_pitch_m or 0.0
        place = pitch * np.asarray(self.cylinder_throw, dtype=np.float64)
        if self.vee is not None:
            place[self.cylinders // 2 :] += self.vee.bank_offset_m
        return place

    @cached_property
    def bearing_share(self) -> FloatArray:
        """Share of each rod's force carried by each bearing, shape (bearings, cylinders).

        Lever rule on a statically determinate throw, each rod by its own place: Newton's law on the
        throw (moments about one of its bearings) splits each connecting rod's force by where it acts
        on the pin, and the two rods of a side-by-side V push in other directions at other times, so
        they cannot be split as one force at the throw's middle. The throw's middle is midway in its
        bay; a side-by-side V's rods stand half the bank offset either side of it (in line and
        fork-and-blade: at it). The bearings are a cylinder pitch apart unless their positions are
        given; without a pitch every rod is taken as midway (half to each bearing).
        """
        share = np.zeros((self.bearing_count, self.cylinders))
        positions = self.bearings.positions_m
        pitch = self.geometry.cylinder_pitch_m
        place = self.cylinder_positions
        throw = np.asarray(self.cylinder_throw)
        middle = np.array([place[throw == k].mean() for k in throw])  # each cylinder's throw's middle [m]
        for c, (b1, b2) in enumerate(self.throw_bearings):
            if pitch is None:
                w2 = 0.5
            elif positions is None:
                w2 = 0.5 + (place[c] - middle[c]) / pitch * (1.0 if b2 > b1 else -1.0)
            else:
                z1, z2 = positions[b1 - 1], positions[b2 - 1]
                # throw 1's middle midway in the first bay, each rod at its place from it
                zc = positions[0] + 0.5 * (positions[1] - positions[0]) + place[c] - middle[0]
                w2 = (zc - z1) / (z2 - z1) if z2 != z1 else 0.5
            if not 0.0 <= w2 <= 1.0:
                raise EngineDescriptionError(
                    f"cylinder {self.cylinder_names[c]}: its rod, {place[c] - middle[c]:.4g} m from its "
                    f"throw's middle, lies outside its bearings {b1} and {b2} ({w2:.3g} of the way from "
                    f"{b1}): check bearings.positions_m and vee.bank_offset_m"
                )
            share[b1 - 1, c] += 1.0 - w2
            share[b2 - 1, c] += w2
        return share


def _known_fields(model: type[BaseModel], loc: tuple[int | str, ...]) -> list[str]:
    """Field names of the model at ``loc`` (for 'did you mean' hints on unknown fields)."""
    current: Any = model
    for part in loc[:-1]:
        if isinstance(part, int):
            continue
        field = current.model_fields.get(part)
        if field is None:
            return []
        annotation = field.annotation
        candidates = [annotation, *getattr(annotation, "__args__", ())]
        current = next((c for c in candidates if isinstance(c, type) and issubclass(c, BaseModel)), None)
        if current is None:
            return []
    return [name for name in current.model_fields if name != "source_dir"]


def _format_errors(error: ValidationError, origin: str) -> str:
    lines = [f"{origin}: invalid engine description ({error.error_count()} problem(s)):"]
    for item in error.errors(include_url=False):
        loc = tuple(item["loc"])
        where = ".".join(str(p) for p in loc) or "(top level)"
        if item["type"] == "extra_forbidden":
            known = _known_fields(Engine, loc)
            close = difflib.get_close_matches(str(loc[-1]), known, n=1)
            hint = f"; did you mean '{close[0]}'?" if close else ""
            lines.append(f"  {where}: unknown field{hint} (known here: {', '.join(known)})")
        elif item["type"] == "missing":
            lines.append(f"  {where}: required field is missing")
        else:
            message = item["msg"].removeprefix("Value error, ")
            value = item.get("input")
            shown = "" if isinstance(value, dict) else f" = {value!r}"
            lines.append(f"  {where}{shown}: {message}")
    return "\n".join(lines)


def parse_engine(data: dict[str, Any], *, origin: str = "engine", source_dir: Path | None = None) -> Engine:
    """Validate a mapping (parsed TOML) into an :class:`Engine`.

    Parameters
    ----------
    data : dict
        The description, as parsed from TOML.
    origin : str
        Name used in error messages (usually the file path).
    source_dir : Path, optional
        Folder that relative paths in the description are resolved against.

    Returns
    -------
    Engine

    Raises
    ------
    EngineDescriptionError
        Listing every problem with its field, value and rule.
    """
    try:
        return Engine.model_validate({**data, "source_dir": source_dir})
    except ValidationError as error:
        raise EngineDescriptionError(_format_errors(error, origin)) from None


def load_engine(path: str | Path) -> Engine:
    """Load and validate an engine description from a TOML file.

    Parameters
    ----------
    path : str or Path
        The TOML file, or the id of a bundled engine (see :func:`bundled_engines`).

    Returns
    -------
    Engine

    Raises
    ------
    EngineDescriptionError
        If the file is missing, is not TOML, or breaks a rule of the description.
    """
    file = Path(path)
    if not file.exists() and (BUNDLED_DIR / f"{path}.toml").exists():
        file = BUNDLED_DIR / f"{path}.toml"
    try:
        text = file.read_text(encoding="utf-8")
    except FileNotFoundError:
        known = ", ".join(sorted(bundled_engines()))
        raise EngineDescriptionError(f"{path}: no such engine file (bundled engines: {known})") from None
    except (OSError, UnicodeDecodeError) as error:
        raise EngineDescriptionError(f"{path}: cannot read engine file: {error}") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as error:
        raise EngineDescriptionError(f"{path}: not valid TOML: {error}") from None
    return parse_engine(data, origin=str(path), source_dir=file.resolve().parent)


def bundled_engines() -> dict[str, Path]:
    """The engine descriptions shipped with the product, by id (file stem)."""
    return {p.stem: p for p in sorted(BUNDLED_DIR.glob("*.toml"))}
