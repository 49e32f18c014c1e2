"""The effects a scene can name: what each takes, what it needs and what it gives.

An effect is named in the scene's ``[effects]`` table with its parameters
(an empty table takes the defaults). Effects are of four groups:

- sources (``inertia``, ``gas``, ``unbalance``, ``external_torque``) give
  forces and torques;
- responses (``crank_speed``, ``bearing_vibration``, ``axial_vibration``)
  turn them into what a sensor measures, and need a source;
- faults (``misfire``, ``weak_cylinder``, ``leaking_cylinder``) change a
  source; ``worn_bearing`` adds knocks where its bearing's load is least;
- sensor effects (``noise``, ``keyphasor_faults``, ``tooth_spacing_errors``,
  ``clipping``, ``gain_error``) change the channels.

Dependencies are resolved from what the scene names, never added silently:
a response without a source of what it needs, or a fault without the source
it changes, is refused with a message that says what to add. An effect that
is not named is not evaluated at all (the simulator asks :func:`named` before
computing anything).

Quantities: ``torque`` (the engine's torque orders), ``bearing_force`` (the
main-bearing force orders), ``cylinder_pressure``, ``crank_speed`` (the
speed fluctuation), ``bearing_acceleration`` (the accelerometer signals).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from monitor.errors import SceneError
from monitor.scene.model import Scene

__all__ = ["EFFECTS", "Effect", "check_effects", "named"]


class _Params(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class InertiaParams(_Params):
    """Inertia forces of the moving parts (pistons, rods, throw unbalance)."""

    kinematics: Literal["exact", "approx"] = "exact"
    rod_model: Literal["rigid", "two-mass"] = "rigid"


class GasParams(_Params):
    """Gas forces from the cylinder pressure (measured trace or parametric cycle).

    ``scale``: each cylinder's heat release as a fraction of the model's (one
    value per cylinder, from cylinder 1; the parametric cycle).
    """

    model: Literal["auto", "parametric", "measured"] = "auto"
    scale: list[Annotated[float, Field(ge=0, le=1.5)]] | None = None


class UnbalanceParams(_Params):
    """An extra rotating unbalance on one crank throw (first order)."""

    throw: Annotated[int, Field(ge=1, description="crank throw (cylinder number)")]
    kgm: Annotated[float, Field(gt=0, description="mass times radius [kg m]")]
    angle_deg: float = Field(default=0.0, description="ahead of the throw's crank pin [deg]")


class CrankSpeedParams(_Params):
    """Crank-speed fluctuation at the tooth wheel.

    ``rigid``: the engine side of the shaft line (free end, throws, flywheel)
    as one rigid body, by its energy balance: right above the first mode (the
    engine against its propeller or generator) and below the crankshaft's own
    modes. ``shaft_line``: the steady forced response
    of the engine's shaft-line model (:mod:`monitor.torsion.shaft_line`) to
    each cylinder's torque orders at the local mean speed, read at the
    tooth-wheel element (``[shaft_line] tooth_wheel``, else the outermost
    free-end element): resonances, a run-up through a critical speed.
    ``variable_inertia``: the engine's equivalent single crank (paper 002: one
    throw, its reciprocating inertia varying twice per revolution, on the shaft
    line's first mode; linearised eq. 6: its twist against a uniformly turning
    flywheel), driven by its own reciprocating inertia (``inertia`` must be
    named) and, if named, one cylinder's gas torque; constant speed only.
    ``damping`` is its damping ratio, ``initial_twist_rad`` its twist at the
    start (with no damping the free vibration it starts goes on: paper 002's
    waveforms and their harmonic content, Table 2).
    """

    model: Literal["rigid", "shaft_line", "variable_inertia"] = "rigid"
    damping: Annotated[float, Field(ge=0, lt=1, description="variable_inertia: damping ratio")] = 0.02
    initial_twist_rad: Annotated[float, Field(ge=0, le=0.05)] = 0.0


class AxialVibrationParams(_Params):
    """Axial vibration of the crankshaft from its torque through the torsional-axial coupling (paper 001).

    Read by sensors with direction "axial" at "main bearing N" (journal N) or
    "free end" (journal 1), as acceleration [m/s^2] or velocity [mm/s]; needs the
    engine's ``[shaft_line.axial]`` data.
    """


class Mode(_Params):
    """One structural mode between a main bearing's force and its accelerometer.

    ``a / F = gain w^2 / (w_n^2 - w^2 + 2 i zeta w_n w)``: ``gain`` is the
    acceleration per force far above the mode (one over the modal mass).
    """

    frequency_hz: Annotated[float, Field(gt=0)]
    damping: Annotated[float, Field(gt=0, lt=1, description="fraction of critical")]
    gain: Annotated[float, Field(gt=0, description="[m/s^2 per N]")]


class BearingVibrationParams(_Params):
    """Accelerations at main-bearing sensors from the bearing forces through a few modes.

    ``modes`` serve every sensor; ``sensors`` may give a sensor its own
    (``sensors = { "mb5-vertical" = [{ frequency_hz = ..., damping = ..., gain = ... }] }``).
    """

    modes: list[Mode] = Field(min_length=1)
    sensors: dict[str, list[Mode]] = Field(default_factory=dict)


class MisfireParams(_Params):
    """Cylinders without combustion: they are motored (compression and expansion only)."""

    cylinders: list[Annotated[int, Field(ge=1)] | str] = Field(
        min_length=1, description='by number, or by name on a V engine ("B3")'
    )


class WeakCylinderParams(_Params):
    """A cylinder whose combustion gives a fraction of the others' heat release."""

    cylinder: Annotated[int, Field(ge=1)] | str = Field(description='by number, or by name ("B3")')
    scale: Annotated[float, Field(ge=0, le=1, description="fraction of the normal heat release")]


class LeakingCylinderParams(_Params):
    """A cylinder that loses charge: its compression (charge) pressure is a fraction of the others'."""

    cylinder: Annotated[int, Field(ge=1)] | str = Field(description='by number, or by name ("B3")')
    compression: Annotated[float, Field(gt=0, le=1, description="fraction of the normal charge pressure")]


class NoiseParams(_Params):
    """Gaussian noise on the named sensors: RMS in each channel's unit."""

    model_config = ConfigDict(extra="allow", frozen=True)


class TorqueOrder(_Params):
    """One order of an external harmonic torque on the crankshaft."""

    order: Annotated[float, Field(gt=0)]
    amplitude_nm: Annotated[float, Field(ge=0, description="peak [N m]")]
    phase_deg: float = 0.0


class ExternalTorqueParams(_Params):
    """A harmonic torque from outside the cylinders (a propeller's blade order, a generator's).

    With the shaft-line crank-speed model it acts on the element ``element``
    (default: the last driven-end element, the propeller or generator).
    """

    orders: list[TorqueOrder] = Field(min_length=1)
    element: str | None = None


class WornBearingParams(_Params):
    """A main bearing with too much clearance: the journal knocks where its load is least.

    At each local minimum of the bearing load's magnitude below its cycle mean
    (where the load turns and the journal crosses its clearance), the bearing's
    sensors get a decaying ring at ``ring_hz`` of ``severity`` peak acceleration
    [m/s^2] (a third of it at the neighbouring bearings; a velocity sensor reads
    the ring's velocity): the higher orders rise at the worn bearing.
    """

    bearing: Annotated[int, Field(ge=1)]
    severity: Annotated[float, Field(gt=0, description="peak acceleration of one knock [m/s^2]")]
    ring_hz: Annotated[float, Field(gt=0)] = 2000.0
    decay_ms: Annotated[float, Field(gt=0)] = 2.0


class KeyphasorFaultsParams(_Params):
    """Lost and spurious keyphasor pulses (at seeded revolutions)."""

    sensor: str
    dropouts: Annotated[int, Field(ge=0)] = 0
    extras: Annotated[int, Field(ge=0)] = 0


class ToothSpacingParams(_Params):
    """Tooth-wheel teeth off their nominal angles: a fixed, seeded error per tooth (RMS, degrees)."""

    sensor: str
    rms_deg: Annotated[float, Field(gt=0, lt=1)]


class ClippingParams(_Params):
    """A channel clipped at its measuring range (the range is stated in the recording)."""

    sensor: str
    limit: Annotated[float, Field(gt=0, description="symmetric limit, the channel's unit")]


class GainErrorParams(_Params):
    """A sensor whose sensitivity is off by a factor."""

    sensor: str
    gain: Annotated[float, Field(gt=0)]


@dataclass(frozen=True)
class Effect:
    """An effect a scene may name.

    Attributes
    ----------
    name : str
    group : str
        "source", "response", "fault" or "sensor".
    params : type
        The pydantic model of its parameters.
    gives : tuple of str
        Quantities it produces.
    needs : tuple of str
        Quantities it needs from another named effect.
    changes : str
        The source a fault changes ("" if none).
    """

    name: str
    group: str
    params: type[BaseModel]
    gives: tuple[str, ...] = ()
    needs: tuple[str, ...] = ()
    changes: str = ""


EFFECTS: dict[str, Effect] = {
    e.name: e
    for e in (
        Effect("inertia", "source", InertiaParams, gives=("torque", "bearing_force")),
        Effect("gas", "source", GasParams, gives=("torque", "bearing_force", "cylinder_pressure")),
        Effect("unbalance", "source", UnbalanceParams, gives=("bearing_force",)),
        Effect("crank_speed", "response", CrankSpeedParams, gives=("crank_speed",), needs=("torque",)),
        Effect(
            "axial_vibration",
            "response",
            AxialVibrationParams,
            gives=("axial_acceleration",),
            needs=("torque",),
        ),
        Effect(
            "bearing_vibration",
            "response",
            BearingVibrationParams,
            gives=("bearing_acceleration",),
            needs=("bearing_force",),
        ),
        Effect("misfire", "fault", MisfireParams, changes="gas"),
        Effect("weak_cylinder", "fault", WeakCylinderParams, changes="gas"),
        Effect("leaking_cylinder", "fault", LeakingCylinderParams, changes="gas"),
        Effect("external_torque", "source", ExternalTorqueParams, gives=("torque",)),
        Effect("worn_bearing", "fault", WornBearingParams, needs=("bearing_force",)),
        Effect("noise", "sensor", NoiseParams),
        Effect("keyphasor_faults", "sensor", KeyphasorFaultsParams),
        Effect("tooth_spacing_errors", "sensor", ToothSpacingParams),
        Effect("clipping", "sensor", ClippingParams),
        Effect("gain_error", "sensor", GainErrorParams),
    )
}


def named(scene: Scene, name: str) -> BaseModel | None:
    """The validated parameters of an effect if the scene names it, else None.

    Parameters
    ----------
    scene : Scene
    name : str
        An effect name (a key of :data:`EFFECTS`).

    Returns
    -------
    pydantic model or None
    """
    if name not in scene.effects:
        return None
    return EFFECTS[name].params.model_validate(scene.effects[name])


def check_effects(scene: Scene, *, origin: str = "scene") -> None:
    """Refuse unknown effects, bad parameters and effects named without their inputs.

    Parameters
    ----------
    scene : Scene
    origin : str, optional
        Where the scene came from, for messages.

    Raises
    ------
    SceneError
    """
    unknown = sorted(set(scene.effects) - set(EFFECTS))
    if unknown:
        raise SceneError(
            f"{origin}: unknown effect(s) {', '.join(unknown)}; known effects: {', '.join(sorted(EFFECTS))}"
        )
    for name, data in scene.effects.items():
        try:
            EFFECTS[name].params.model_validate(data)
        except ValidationError as error:
            problems = []
            for problem in error.errors():
                where = ".".join(str(p) for p in problem["loc"])
                text = "unknown field" if problem["type"] == "extra_forbidden" else problem["msg"]
                fields = ", ".join(EFFECTS[name].params.model_fields)
                problems.append(
                    f"{where}: {text}"
                    + (f" (fields: {fields})" if problem["type"] == "extra_forbidden" else "")
                )
            raise SceneError(f"{origin}: effect {name!r}: " + "; ".join(problems)) from None
    given = {q for n in scene.effects for q in EFFECTS[n].gives}
    for name in scene.effects:
        effect = EFFECTS[name]
        for quantity in effect.needs:
            if quantity not in given:
                sources = sorted(e.name for e in EFFECTS.values() if quantity in e.gives)
                raise SceneError(
                    f"{origin}: effect {name!r} needs a {quantity.replace('_', ' ')}: add one of "
                    f"{', '.join(sources)} to [effects]"
                )
        if effect.changes and effect.changes not in scene.effects:
            raise SceneError(
                f"{origin}: effect {name!r} changes {effect.changes!r}: add {effect.changes} to [effects]"
            )
    kinds = {s.name: s.kind for s in scene.sensors}
    for name, wanted in (
        ("keyphasor_faults", ("keyphasor",)),
        ("tooth_spacing_errors", ("tooth",)),
        ("clipping", ("acceleration", "velocity", "pressure")),
        ("gain_error", ("acceleration", "velocity", "pressure")),
    ):
        params = named(scene, name)
        if params is None:
            continue
        target = params.sensor  # type: ignore[attr-defined]
        if kinds.get(target) not in wanted:
            raise SceneError(
                f"{origin}: effect {name!r}: sensor {target!r} is not a {' or '.join(wanted)} sensor of the "
                f"scene; sensors: {', '.join(f'{n} ({k})' for n, k in kinds.items())}"
            )
    vibration = named(scene, "bearing_vibration")
    if isinstance(vibration, BearingVibrationParams):
        unknown_sensors = sorted(set(vibration.sensors) - set(kinds))
        if unknown_sensors:
            raise SceneError(
                f"{origin}: effect 'bearing_vibration' gives modes to {', '.join(unknown_sensors)}, "
                f"which the scene does not have; sensors: {', '.join(kinds)}"
            )
    noise = named(scene, "noise")
    if noise is not None:
        sensors = {s.name for s in scene.sensors}
        for key, value in (noise.model_extra or {}).items():
            if key not in sensors:
                raise SceneError(
                    f"{origin}: effect 'noise' names sensor {key!r}, which the scene does not have; "
                    f"sensors: {', '.join(sorted(sensors))}"
                )
            if not isinstance(value, int | float) or value < 0:
                raise SceneError(f"{origin}: effect 'noise': {key} = {value!r}: expected an RMS >= 0")
