"""The engine's inertias about the crankshaft, from its description: throws, shaft line, engine side.

Each crank throw carries its own rotating inertia, the rod's crank-pin share
``m_rot R^2`` and the reciprocating parts' inertia ``m_rec (dx/dalpha)^2``
(exact kinematics), which varies through a revolution: its mean, or its value
at a given crank angle.  Along the shaft the description lists the free-end
elements, the throws and the driven-end elements (:func:`node_inertias`, the
order :func:`monitor.torsion.shaft_line.shaft_line_of` builds its nodes in).

The engine side (free end, throws, and the driven end up to the flywheel)
turns as one rigid body below the crankshaft's own modes
(:func:`engine_side_inertia`); the inertia a torque on it meets at each
frequency adds the driven end through its shafts (:func:`engine_side_inertia_at`).
The predicted crank-angle fluctuation and the diagnosis' crank-speed model rest
on these; the torsion models build their nodes from them.

References
----------
002: Pasricha and Hashim (mean and varying inertia of the reciprocating parts).
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
import numpy.typing as npt

from monitor.errors import ModelError
from monitor.model.banks import slave_cylinders, slave_masses
from monitor.model.engine import Engine
from monitor.model.kinematics import piston_x_derivatives
from monitor.types import ComplexArray, FloatArray

__all__ = [
    "engine_side_inertia",
    "engine_side_inertia_at",
    "mean_moving_inertia",
    "mean_reciprocating_inertia",
    "node_inertias",
    "reciprocating_inertia",
    "slave_inertia",
    "throw_inertia",
]


def reciprocating_inertia(engine: Engine, crank_angle: npt.ArrayLike) -> FloatArray:
    """Inertia of one cylinder's reciprocating parts about the crankshaft, ``m_rec (dx/dalpha)^2``.

    Parameters
    ----------
    engine : Engine
        The engine (two-mass reciprocating mass, exact kinematics).
    crank_angle : array_like
        The cylinder's own crank angle from TDC [rad].

    Returns
    -------
    ndarray
        [kg m^2]; its mean over a revolution is ``m_rec R^2 (1/2 + lambda^2 / 8 + ...)``.
    """
    dx = piston_x_derivatives(crank_angle, engine.crank_radius, engine.rod_ratio)[1]
    return engine.reciprocating_mass * dx * dx


def slave_inertia(engine: Engine, crank_angle: npt.ArrayLike) -> FloatArray:
    """Inertia of an articulated rod's slave cylinder's moving masses about the crankshaft.

    Its piston share ``m_s s'^2`` and its rod's knuckle share ``m_k |K'|^2``
    (:meth:`monitor.model.articulated.ArticulatedRod.slave_inertia`): the knuckle share moves with
    the knuckle pin, not with the crank pin, so it varies through a revolution too.

    Parameters
    ----------
    engine : Engine
        With articulated rods.
    crank_angle : array_like
        The slave's own crank angle from its nominal TDC, a bank angle after its master's [rad].

    Returns
    -------
    ndarray
        [kg m^2].

    Raises
    ------
    ModelError
        For an engine without articulated rods.
    """
    rod, vee = engine.articulated, engine.vee
    if rod is None or vee is None:
        raise ModelError(f"engine {engine.id!r} has no articulated rods: it has no slave cylinders")
    reciprocating, knuckle = slave_masses(vee, engine.masses.piston_assembly_kg)
    angle = np.asarray(crank_angle, dtype=np.float64) + rod.bank_angle  # the master's crank angle
    return rod.slave_inertia(angle, reciprocating_mass=reciprocating, knuckle_mass=knuckle)


def _moving(engine: Engine, own_angles: FloatArray) -> FloatArray:
    """Each cylinder's moving masses' inertia at its own crank angle (shape (cylinders, ...))."""
    slaves = slave_cylinders(engine.cylinders, engine.vee)
    moving = reciprocating_inertia(engine, own_angles)
    if slaves.any():
        moving[slaves] = slave_inertia(engine, own_angles[slaves])
    return np.asarray(moving)


def mean_reciprocating_inertia(engine: Engine) -> float:
    """Mean of :func:`reciprocating_inertia` over a revolution (spectrally exact quadrature).

    Parameters
    ----------
    engine : Engine

    Returns
    -------
    float
        [kg m^2].
    """
    grid = np.linspace(0.0, 2 * math.pi, 512, endpoint=False)
    return float(np.mean(reciprocating_inertia(engine, grid)))


def mean_moving_inertia(engine: Engine) -> FloatArray:
    """Each cylinder's moving masses' mean inertia over a revolution, by index: its reciprocating parts
    (:func:`mean_reciprocating_inertia`), or on an articulated rod's slave its piston and knuckle
    shares (:func:`slave_inertia`) [kg m^2].

    Parameters
    ----------
    engine : Engine

    Returns
    -------
    ndarray, shape (cylinders,)
    """
    moving = np.full(engine.cylinders, mean_reciprocating_inertia(engine))
    slaves = slave_cylinders(engine.cylinders, engine.vee)
    if slaves.any():  # every slave alike: its mean once
        grid = np.linspace(0.0, 2 * math.pi, 512, endpoint=False)
        moving[slaves] = float(np.mean(slave_inertia(engine, grid)))
    return moving


def throw_inertia(engine: Engine) -> float:
    """One throw's rotating inertia with its rods' crank-pin shares, ``I_throw + r m_rot R^2`` [kg m^2].

    ``r`` rods on the pin: one in line, two on a V.

    Parameters
    ----------
    engine : Engine
        With its ``[shaft_line]``.

    Raises
    ------
    ModelError
        If the engine has no ``[shaft_line]``.
    """
    if engine.shaft_line is None:
        raise ModelError(f"engine {engine.id!r} has no [shaft_line] description")
    # a slave rod's knuckle share is the slave's own (slave_inertia): it does not turn with the crank pin
    rods = (engine.cylinders - int(slave_cylinders(engine.cylinders, engine.vee).sum())) // engine.throws
    return engine.shaft_line.throw_inertia_kgm2 + rods * engine.rotating_rod_mass * engine.crank_radius**2


def throw_node_names(engine: Engine) -> list[str]:
    """The shaft-line node of each cylinder's throw, by cylinder index: ``cylinder c`` in line (one
    throw a cylinder), ``throw k`` on a V (A k and B k on it).

    Parameters
    ----------
    engine : Engine

    Returns
    -------
    list of str
    """
    if engine.vee is None:
        return [f"cylinder {c}" for c in range(1, engine.cylinders + 1)]
    return [f"throw {k + 1}" for k in engine.cylinder_throw]


def node_inertias(
    engine: Engine, *, reciprocating: Literal["mean", "none"] | float = "mean"
) -> list[tuple[str, float]]:
    """The shaft line's nodes in order along the shaft, each with its inertia [kg m^2].

    Parameters
    ----------
    engine : Engine
        With a ``[shaft_line]`` table.
    reciprocating : {"mean", "none"} or float
        The reciprocating parts' inertia on each throw: its mean over a
        revolution (exact kinematics), none, or its value when cylinder 1's
        crank stands at this angle (a float [rad]; each throw at its own
        angle), to follow the natural frequencies through a revolution.

    Returns
    -------
    list of (str, float)
        Free-end elements (outermost first), the throws from the free end (named by
        :func:`throw_node_names`: ``cylinder 1`` ... in line, ``throw 1`` ... on a V), the driven-end
        elements.

    Raises
    ------
    ModelError
        If the engine has no ``[shaft_line]``, or for an unknown ``reciprocating``.
    """
    line = engine.shaft_line
    if line is None:
        raise ModelError(f"engine {engine.id!r} has no [shaft_line] description")
    if reciprocating == "mean":
        moving = mean_moving_inertia(engine)
    elif reciprocating == "none":
        moving = np.zeros(engine.cylinders)
    elif isinstance(reciprocating, float) and math.isfinite(reciprocating):
        moving = _moving(engine, reciprocating - engine.firing_angles)
    else:
        raise ModelError(f"reciprocating = {reciprocating!r}: expected 'mean', 'none' or a crank angle [rad]")
    # each throw with its rods' reciprocating parts (both cylinders' on a V, each at its own angle)
    on_throw = np.bincount(engine.cylinder_throw, weights=moving, minlength=engine.throws)
    throws = throw_inertia(engine) + on_throw
    names = throw_node_names(engine)
    first_of = [names[engine.cylinder_throw.index(k)] for k in range(engine.throws)]
    order = list(range(engine.throws))
    if engine.cylinder_numbering == "from flywheel end":
        order.reverse()
    return (
        [(element.name, element.inertia_kgm2) for element in reversed(line.free_end)]
        + [(first_of[k], float(throws[k])) for k in order]
        + [(element.name, element.inertia_kgm2) for element in line.driven_end]
    )


def engine_side_inertia(engine: Engine) -> float:
    """The engine side of the shaft line as one rigid body [kg m^2].

    Free-end elements, throws (reciprocating parts at their mean) and the
    driven-end elements up to the flywheel: above the first mode (the engine
    against its propeller or generator: 3.3 Hz on the 7K98MC, 3.5 Hz on the
    6L32) the engine side turns as one body up to the crankshaft's own modes
    (24 Hz on the 7K98MC, 54 Hz on the 6L32), below which their firing orders lie;
    without a flywheel, the throws and free end.

    Parameters
    ----------
    engine : Engine
        With its ``[shaft_line]``.

    Returns
    -------
    float
        [kg m^2]

    Raises
    ------
    ModelError
        If the engine has no ``[shaft_line]``.
    """
    nodes, last = _engine_side(engine)
    return float(sum(inertia for _, inertia in nodes[: last + 1]))


def _engine_side(engine: Engine) -> tuple[list[tuple[str, float]], int]:
    """The shaft line's nodes and the index of the engine side's last node (the flywheel, or last throw)."""
    if engine.shaft_line is None:
        raise ModelError(f"engine {engine.id!r} has no [shaft_line]: its inertias are unknown")
    nodes = node_inertias(engine)
    names = [name for name, _ in nodes]
    last = max(names.index(name) for name in throw_node_names(engine))
    for element in engine.shaft_line.driven_end:
        if element.kind == "flywheel":
            last = names.index(element.name)
            break
    return nodes, last


def engine_side_inertia_at(engine: Engine, angular_frequency: npt.ArrayLike) -> ComplexArray:
    """The inertia a torque on the engine side meets at each frequency [kg m^2], complex.

    The engine side (:func:`engine_side_inertia`) turns as one body; the driven end beyond it
    (propeller, generator, a shaft) follows through its shafts.  Seen from the engine side's last
    node, the elements beyond it, from the far end inwards, have the dynamic stiffness
    ``Z_i = -w^2 J_i + i w c_i + Z'_(i+1)`` and, through their shaft ``k_i + i w d_i``,
    ``Z'_i = (k_i + i w d_i) Z_i / (k_i + i w d_i + Z_i)``; the torque on the engine side for an
    angle ``theta`` is ``(-w^2 J_engine + Z'_first) theta``, so ``J(w) = J_engine - Z'_first / w^2``.
    Far below the engine-against-load mode the whole line turns as one (``J`` the sum of every
    inertia); far above it the driven end stands still (``J`` the engine side's), the rigid
    engine side's usual regime (a propeller or generator on a flexible shaft or coupling, its mode
    at a few hertz).  The driven end is taken in this way only where that mode (two masses: the
    engine side, and everything beyond on the first shaft) lies above every frequency asked for: a
    stiff coupling; where it lies among them the orders straddle a resonance that no rigid body
    describes, and the engine side alone is kept, as :func:`engine_side_inertia` gives it.

    Parameters
    ----------
    engine : Engine
        With its ``[shaft_line]``.
    angular_frequency : array_like
        [rad/s], positive.

    Returns
    -------
    ndarray, complex, shape of ``angular_frequency``
        [kg m^2]; the imaginary part is the driven end's damping seen by the engine side.

    Raises
    ------
    ModelError
        If the engine has no ``[shaft_line]``, or for a frequency that is not positive.
    """
    w = np.asarray(angular_frequency, dtype=np.float64)
    if np.any(~np.isfinite(w)) or np.any(w <= 0):
        raise ModelError(
            "engine_side_inertia_at: the angular frequencies must be positive and finite [rad/s]"
        )
    nodes, last = _engine_side(engine)
    names = [name for name, _ in nodes]
    rigid = float(sum(inertia for _, inertia in nodes[: last + 1]))
    driven = engine.shaft_line.driven_end if engine.shaft_line is not None else []
    beyond = [e for e in driven if names.index(e.name) > last]
    tail = np.zeros(w.shape, dtype=np.complex128)
    if beyond:
        rest = sum(e.inertia_kgm2 for e in beyond)
        first = beyond[0].stiffness_to_previous_nm_per_rad
        mode = math.sqrt(first * (1 / rigid + 1 / rest)) if rest > 0 else math.inf
        if mode <= float(w.max(initial=0.0)):
            beyond = []  # a flexible coupling: above its mode the driven end is left to itself
    for element in reversed(beyond):
        own = -(w**2) * element.inertia_kgm2 + 1j * w * element.absolute_damping_nms_per_rad + tail
        shaft = element.stiffness_to_previous_nm_per_rad + 1j * w * element.relative_damping_nms_per_rad
        total = shaft + own
        # at a free resonance of the tail (total = 0) the tail holds the engine side still: huge stiffness
        tail = np.where(
            np.abs(total) > 0, shaft * own / np.where(np.abs(total) > 0, total, 1.0), shaft * 1e12
        )
    return np.asarray(rigid - tail / w**2)
