"""Lumped torsional model of a shaft line: natural frequencies, modes, forced response, Campbell data.

A shaft line is a set of nodes, each a rotational degree of freedom with a
polar moment of inertia, joined by shaft elements (torsional stiffness,
relative damping, and optionally the shaft's own distributed inertia), with
springs and dampers to ground (propeller, generator) and gear meshes that tie
two nodes' rotations together.  Assembly gives the mass, stiffness and
damping matrices ``M, K, C``; gear meshes are linear constraints
``R_a theta_a + R_b theta_b = 0`` removed by a null-space transformation
``theta = T q`` (``M_q = T^T M T`` and so on).

A shaft element's own inertia ``I_s`` enters either lumped (half at each
end) or with the consistent matrix ``I_s / 6 [[2, 1], [1, 2]]`` of a uniform
shaft with linear interpolation of the twist (the finite-element convention,
which converges to the continuous shaft as it is divided).

- Natural frequencies and modes: ``K v = w^2 M v`` (undamped), solved as a
  symmetric-definite problem; massless nodes are condensed out exactly first.
- Forced response at angular frequency ``w``: ``(K + j w C - w^2 M) Theta = Tq``
  solved without forming an inverse; its condition number is reported.
- An engine's shaft line is built from its description
  (:func:`shaft_line_of`): one node per crank throw, with the throw's
  rotating inertia, the rod's crank-pin share ``m_rot R^2`` and the
  reciprocating parts' inertia ``m_rec (dx/dalpha)^2`` (exact kinematics):
  its mean over a revolution, or its value at a given crank angle to follow
  the natural frequencies through a revolution (the variation itself is the
  subject of :mod:`monitor.torsion.variable_inertia`); then the free-end and
  driven-end elements (the inertias from :mod:`monitor.model.inertia`).  The forced
  response to the engine's excitation orders uses each cylinder's torque orders, with
  their phases, from :func:`monitor.model.excitation.cylinder_torque_orders`; the
  speed at the tooth wheel per unit torque at each throw is
  :func:`tooth_wheel_receptance`.

References
----------
Friswell, Penny, Garvey, Lees, Dynamics of Rotating Machines, Cambridge
University Press 2010, ch. 9 (torsional models, gears, distributed shafts).
002: Pasricha and Hashim (mean and varying inertia of the reciprocating parts).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import numpy.typing as npt
import scipy.linalg

from monitor.errors import ModelError
from monitor.model.engine import Engine
from monitor.model.excitation import cylinder_torque_orders
from monitor.model.inertia import node_inertias, throw_node_names
from monitor.types import ComplexArray, FloatArray

__all__ = [
    "CampbellData",
    "ForcedResponse",
    "GearMesh",
    "Modes",
    "Node",
    "ShaftElement",
    "ShaftLineModel",
    "campbell",
    "engine_forced_response",
    "shaft_line_of",
    "tooth_wheel_receptance",
]


@dataclass(frozen=True)
class Node:
    """A rotational degree of freedom.

    Attributes
    ----------
    name : str
    inertia : float
        Polar moment of inertia [kg m^2].
    stiffness_to_ground : float
        [N m/rad].
    damping_to_ground : float
        Absolute damping (propeller, generator) [N m s/rad].
    """

    name: str
    inertia: float
    stiffness_to_ground: float = 0.0
    damping_to_ground: float = 0.0


@dataclass(frozen=True)
class ShaftElement:
    """A shaft between two nodes.

    Attributes
    ----------
    node_a, node_b : int
        Node indices.
    stiffness : float
        Torsional stiffness [N m/rad].
    damping : float
        Relative damping [N m s/rad].
    inertia : float
        The shaft's own polar inertia, whole length [kg m^2].
    mass_model : {"consistent", "lumped"}
        How that inertia is distributed to the two nodes.
    """

    node_a: int
    node_b: int
    stiffness: float
    damping: float = 0.0
    inertia: float = 0.0
    mass_model: Literal["consistent", "lumped"] = "consistent"


@dataclass(frozen=True)
class GearMesh:
    """A rigid gear mesh: ``radius_a theta_a + radius_b theta_b = 0`` (the gears counter-rotate).

    Attributes
    ----------
    node_a, node_b : int
    radius_a, radius_b : float
        Pitch radii (only their ratio matters) [m].
    """

    node_a: int
    node_b: int
    radius_a: float
    radius_b: float


@dataclass(frozen=True)
class Modes:
    """Undamped natural frequencies and mode shapes.

    Attributes
    ----------
    frequencies : ndarray, shape (n_modes,)
        Natural angular frequencies, increasing, rigid-body modes excluded [rad/s].
    shapes : ndarray, shape (n_nodes, n_modes)
        Mode shapes at every node, mass-normalised in the reduced coordinates,
        largest entry positive.
    rigid_body_modes : int
        Number of zero-frequency modes found (1 for a free shaft line).
    node_names : tuple of str
    """

    frequencies: FloatArray
    shapes: FloatArray
    rigid_body_modes: int
    node_names: tuple[str, ...]

    @property
    def frequencies_hz(self) -> FloatArray:
        """Natural frequencies [Hz]."""
        return self.frequencies / (2 * math.pi)


@dataclass
class ShaftLineModel:
    """Assembled torsional model of a shaft line.

    Parameters
    ----------
    nodes : sequence of Node
        The degrees of freedom, in order.
    shafts : sequence of ShaftElement
        Elements between nodes.
    gears : sequence of GearMesh, optional
        Rigid meshes between nodes.
    """

    nodes: Sequence[Node]
    shafts: Sequence[ShaftElement]
    gears: Sequence[GearMesh] = field(default_factory=tuple)

    def __post_init__(self) -> None:
        n = len(self.nodes)
        if n == 0:
            raise ModelError("a shaft line needs at least one node")
        for node in self.nodes:
            for name, value in (
                ("inertia", node.inertia),
                ("stiffness_to_ground", node.stiffness_to_ground),
                ("damping_to_ground", node.damping_to_ground),
            ):
                if not (math.isfinite(value) and value >= 0):
                    raise ModelError(
                        f"node {node.name!r}: {name} = {value!r}: expected a non-negative finite value"
                    )
        for i, s in enumerate(self.shafts):
            if not (0 <= s.node_a < n and 0 <= s.node_b < n and s.node_a != s.node_b):
                raise ModelError(
                    f"shaft {i}: nodes {s.node_a}, {s.node_b}: expected two different nodes in 0..{n - 1}"
                )
            if not (math.isfinite(s.stiffness) and s.stiffness > 0):
                raise ModelError(
                    f"shaft {i}: stiffness = {s.stiffness!r}: expected a positive value [N m/rad]"
                )
            if s.damping < 0 or s.inertia < 0:
                raise ModelError(
                    f"shaft {i}: damping = {s.damping!r} N m s/rad, inertia = {s.inertia!r} kg m^2: "
                    "expected non-negative values"
                )
        for i, g in enumerate(self.gears):
            if not (0 <= g.node_a < n and 0 <= g.node_b < n and g.radius_a > 0 and g.radius_b > 0):
                raise ModelError(
                    f"gear mesh {i}: nodes {g.node_a}, {g.node_b}, radii {g.radius_a!r}, {g.radius_b!r}: "
                    f"expected two nodes in 0..{n - 1} and positive radii"
                )
        self.mass, self.stiffness, self.damping = self._assemble()
        self.transform = self._constraints()

    @property
    def node_names(self) -> tuple[str, ...]:
        """Names of the nodes, in order."""
        return tuple(node.name for node in self.nodes)

    def index(self, name: str) -> int:
        """Index of the node called ``name``."""
        try:
            return self.node_names.index(name)
        except ValueError:
            raise ModelError(f"no node named {name!r}; nodes: {', '.join(self.node_names)}") from None

    def _assemble(self) -> tuple[FloatArray, FloatArray, FloatArray]:
        n = len(self.nodes)
        m = np.diag([node.inertia for node in self.nodes]).astype(np.float64)
        k = np.diag([node.stiffness_to_ground for node in self.nodes]).astype(np.float64)
        c = np.diag([node.damping_to_ground for node in self.nodes]).astype(np.float64)
        for s in self.shafts:
            idx = np.ix_([s.node_a, s.node_b], [s.node_a, s.node_b])
            k[idx] += s.stiffness * np.array([[1.0, -1.0], [-1.0, 1.0]])
            c[idx] += s.damping * np.array([[1.0, -1.0], [-1.0, 1.0]])
            if s.inertia:
                if s.mass_model == "consistent":
                    m[idx] += s.inertia / 6.0 * np.array([[2.0, 1.0], [1.0, 2.0]])
                else:
                    m[idx] += s.inertia / 2.0 * np.eye(2)
        if n and not np.all(np.isfinite(m)):
            raise ModelError("non-finite inertia in the shaft line")
        return m, k, c

    def _constraints(self) -> FloatArray:
        n = len(self.nodes)
        if not self.gears:
            return np.eye(n)
        rows = np.zeros((len(self.gears), n))
        for i, g in enumerate(self.gears):
            rows[i, g.node_a] += g.radius_a
            rows[i, g.node_b] += g.radius_b
        basis = scipy.linalg.null_space(rows)
        if basis.shape[1] != n - len(self.gears):
            raise ModelError("gear meshes are not independent (a closed loop of gears?)")
        return np.asarray(basis)

    def reduced(self) -> tuple[FloatArray, FloatArray, FloatArray]:
        """``T^T M T, T^T K T, T^T C T`` in the constraint-free coordinates."""
        t = self.transform
        return t.T @ self.mass @ t, t.T @ self.stiffness @ t, t.T @ self.damping @ t

    def modes(self) -> Modes:
        """Undamped natural frequencies and mode shapes.

        Returns
        -------
        Modes

        Notes
        -----
        Degrees of freedom without inertia are condensed out exactly (static
        condensation), then ``K v = w^2 M v`` is solved by ``scipy.linalg.eigh``.
        Eigenvalues below ``1e-9`` of the largest are counted as rigid-body modes.
        """
        m, k, _ = self.reduced()
        scale = float(np.max(np.abs(np.diag(m)), initial=0.0))
        if scale <= 0:
            raise ModelError("the shaft line has no inertia")
        massless = np.abs(np.diag(m)) <= 1e-14 * scale
        if np.any(massless) and np.any(np.abs(m[np.ix_(massless, ~massless)]) > 0):
            raise ModelError(
                "a degree of freedom without inertia is coupled by inertia to another: cannot condense"
            )
        keep = ~massless
        if np.any(massless):
            k_ss = k[np.ix_(massless, massless)]
            k_sm = k[np.ix_(massless, keep)]
            condensation = -scipy.linalg.solve(k_ss, k_sm, assume_a="sym")
            full = np.zeros((m.shape[0], int(keep.sum())))
            full[keep] = np.eye(int(keep.sum()))
            full[massless] = condensation
            m_r = full.T @ m @ full
            k_r = full.T @ k @ full
        else:
            full = np.eye(m.shape[0])
            m_r, k_r = m, k
        values, vectors = scipy.linalg.eigh(k_r, m_r)
        top = max(float(np.max(np.abs(values))), 1e-300)
        rigid = values <= 1e-9 * top
        shapes = self.transform @ (full @ vectors[:, ~rigid])
        signs = np.sign(shapes[np.argmax(np.abs(shapes), axis=0), np.arange(shapes.shape[1])])
        return Modes(np.sqrt(values[~rigid]), shapes * signs, int(rigid.sum()), self.node_names)

    def dynamic_stiffness(self, frequency: float) -> ComplexArray:
        """``B(w) = K + j w C - w^2 M`` in the reduced coordinates.

        Parameters
        ----------
        frequency : float
            w [rad/s].

        Returns
        -------
        ndarray
        """
        m, k, c = self.reduced()
        return np.asarray(k + 1j * frequency * c - frequency**2 * m, dtype=np.complex128)

    def harmonic_response(self, frequency: float, torque: npt.ArrayLike) -> tuple[ComplexArray, float]:
        """Steady complex angles at every node for a harmonic torque ``Re(T exp(j w t))``.

        Parameters
        ----------
        frequency : float
            w [rad/s].
        torque : array_like, shape (n_nodes, ...)
            Complex torque amplitude at each node [N m].

        Returns
        -------
        angles : ndarray, shape (n_nodes, ...)
            Complex angle amplitudes [rad].
        condition : float
            Condition number of the dynamic stiffness (large near an undamped resonance).

        Raises
        ------
        ModelError
            If the dynamic stiffness is singular (undamped resonance exactly).
        """
        b = self.dynamic_stiffness(frequency)
        rhs = self.transform.T @ np.asarray(torque, dtype=np.complex128)
        condition = float(np.linalg.cond(b))
        if not math.isfinite(condition) or condition > 1e15:
            raise ModelError(
                f"dynamic stiffness is singular at {frequency:.6g} rad/s (condition {condition:.3g}): "
                "an undamped resonance; add damping or move off the natural frequency"
            )
        q = scipy.linalg.solve(b, rhs)
        return self.transform @ q, condition


# ------------------------------------------------------------------------------- engine shaft lines
def shaft_line_of(
    engine: Engine, *, reciprocating: Literal["mean", "none"] | float = "mean"
) -> ShaftLineModel:
    """The shaft-line model of an engine description.

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
    ShaftLineModel
        Nodes in order along the shaft: free-end elements (outermost first),
        the throws (named ``cylinder 1`` ...), the driven-end elements.
    """
    named = node_inertias(engine, reciprocating=reciprocating)
    line = engine.shaft_line
    assert line is not None  # node_inertias raised otherwise
    free = list(reversed(line.free_end))
    grounded = (
        [e.absolute_damping_nms_per_rad for e in free]
        + [0.0] * engine.throws
        + [e.absolute_damping_nms_per_rad for e in line.driven_end]
    )
    nodes = [
        Node(name, inertia, damping_to_ground=damping)
        for (name, inertia), damping in zip(named, grounded, strict=True)
    ]
    shafts: list[ShaftElement] = []
    for i in range(len(free) - 1):
        # element i+1 is nearer the engine; its stiffness joins it to element i
        shafts.append(
            ShaftElement(
                i, i + 1, free[i].stiffness_to_previous_nm_per_rad, free[i].relative_damping_nms_per_rad
            )
        )
    first_throw = len(free)
    if free:
        shafts.append(
            ShaftElement(
                first_throw - 1,
                first_throw,
                free[-1].stiffness_to_previous_nm_per_rad,
                free[-1].relative_damping_nms_per_rad,
            )
        )
    for i in range(first_throw, first_throw + engine.throws - 1):
        shafts.append(ShaftElement(i, i + 1, line.throw_stiffness_nm_per_rad))
    previous = first_throw + engine.throws - 1
    for element in line.driven_end:
        shafts.append(
            ShaftElement(
                previous,
                previous + 1,
                element.stiffness_to_previous_nm_per_rad,
                element.relative_damping_nms_per_rad,
            )
        )
        previous += 1
    return ShaftLineModel(nodes, shafts)


def tooth_wheel_receptance(engine: Engine, orders: FloatArray, crank_speed: float) -> ComplexArray:
    """Speed at the tooth wheel per unit torque at each throw, per order.

    Parameters
    ----------
    engine : Engine
        With its ``[shaft_line]`` (the tooth wheel's element, else the first node).
    orders : ndarray, shape (n_orders,)
        [-].
    crank_speed : float
        Mean crank speed [rad/s].

    Returns
    -------
    ndarray, complex, shape (n_cylinders, n_orders)
        [rad/s per N m].

    Raises
    ------
    ModelError
        Without a ``[shaft_line]``.
    """
    if engine.shaft_line is None:
        raise ModelError(f"transfer 'shaft-line' needs the [shaft_line] of engine {engine.id!r}")
    line = shaft_line_of(engine)
    probe = line.index(engine.shaft_line.tooth_wheel or line.node_names[0])
    throws = [line.index(name) for name in throw_node_names(engine)]
    out = np.zeros((engine.cylinders, orders.size), dtype=np.complex128)
    for j, k in enumerate(orders):
        for i, node in enumerate(throws):
            unit = np.zeros(len(line.nodes))
            unit[node] = 1.0
            angle = line.harmonic_response(float(k * crank_speed), unit)[0][probe]
            out[i, j] = 1j * k * crank_speed * angle
    return out


@dataclass(frozen=True)
class ForcedResponse:
    """Steady torsional response of an engine's shaft line to its excitation orders.

    Attributes
    ----------
    speed : ndarray, shape (n_speeds,)
        Crank speeds [rad/s].
    orders : ndarray, shape (n_orders,)
        Excitation orders (order 0 excluded) [-].
    angle : ndarray, shape (n_nodes, n_speeds, n_orders)
        Complex vibratory angle of every node per order [rad], phase relative to TDC of cylinder 1.
    condition : ndarray, shape (n_speeds, n_orders)
        Condition number of each solve.
    node_names : tuple of str
    """

    speed: FloatArray
    orders: FloatArray
    angle: ComplexArray
    condition: FloatArray
    node_names: tuple[str, ...]

    @property
    def speed_fluctuation(self) -> ComplexArray:
        """Complex angular-speed amplitude per node, speed and order, ``j k omega Theta`` [rad/s]."""
        w = self.speed[None, :, None] * self.orders[None, None, :]
        return 1j * w * self.angle

    def total_angle(self) -> FloatArray:
        """Sum of the order amplitudes per node and speed (an upper bound of the peak) [rad]."""
        return np.asarray(np.abs(self.angle).sum(axis=-1))


def engine_forced_response(
    engine: Engine,
    speeds: npt.ArrayLike,
    *,
    load: float | Literal["propeller"] = "propeller",
    max_order: float = 12,
    line: ShaftLineModel | None = None,
) -> ForcedResponse:
    """Forced response of an engine's shaft line over a speed range.

    Parameters
    ----------
    engine : Engine
        With ``[shaft_line]`` and a gas-force model.
    speeds : array_like
        Crank speeds, > 0 [rad/s].
    load : float or "propeller"
        Fraction of rated IMEP, or "propeller" for the propeller law
        (IMEP proportional to speed squared, rated at rated speed) [-].
    max_order : float, optional
        Highest excitation order [-].
    line : ShaftLineModel, optional
        The model to excite (default: :func:`shaft_line_of` the engine).

    Returns
    -------
    ForcedResponse
    """
    model_line = line if line is not None else shaft_line_of(engine)
    throw_nodes = [model_line.index(name) for name in throw_node_names(engine)]
    w, orders, cylinder_torque = cylinder_torque_orders(engine, speeds, load=load, max_order=max_order)
    angle = np.zeros((len(model_line.nodes), w.size, orders.size), dtype=np.complex128)
    condition = np.zeros((w.size, orders.size))
    for i, speed in enumerate(w):
        torque = np.zeros((len(model_line.nodes), orders.size), dtype=np.complex128)
        np.add.at(torque, throw_nodes, cylinder_torque[i])  # a V's two cylinders on one throw
        for j, k in enumerate(orders):
            angle[:, i, j], condition[i, j] = model_line.harmonic_response(float(k * speed), torque[:, j])
    return ForcedResponse(w, orders, angle, condition, model_line.node_names)


@dataclass(frozen=True)
class CampbellData:
    """Natural frequencies against engine speed, with the excitation-order lines.

    Attributes
    ----------
    frequencies_hz : ndarray, shape (n_modes,)
        Natural frequencies (constant with speed in this model) [Hz].
    orders : ndarray
        Excitation orders drawn [-].
    critical_speeds_rpm : list of (int, float, float)
        (mode number from 1, order, crank speed [rpm]) where ``order x speed`` meets a
        natural frequency, within the speed range.
    speed_range_rpm : (float, float)
    """

    frequencies_hz: FloatArray
    orders: FloatArray
    critical_speeds_rpm: list[tuple[int, float, float]]
    speed_range_rpm: tuple[float, float]


def campbell(modes: Modes, orders: npt.ArrayLike, speed_range_rpm: tuple[float, float]) -> CampbellData:
    """Critical speeds where an excitation order meets a natural frequency.

    Parameters
    ----------
    modes : Modes
        Natural frequencies.
    orders : array_like
        Excitation orders [-].
    speed_range_rpm : (float, float)
        Crank-speed range [rpm].

    Returns
    -------
    CampbellData
    """
    k = np.asarray(orders, dtype=np.float64)
    lo, hi = speed_range_rpm
    if not 0 <= lo < hi:
        raise ModelError(f"speed_range_rpm = {speed_range_rpm!r}: expected 0 <= low < high")
    critical = []
    for mode, f in enumerate(modes.frequencies_hz, start=1):
        for order in k:
            rpm = 60.0 * float(f) / float(order)
            if lo <= rpm <= hi:
                critical.append((mode, float(order), rpm))
    return CampbellData(modes.frequencies_hz, k, sorted(critical, key=lambda c: c[2]), (float(lo), float(hi)))
