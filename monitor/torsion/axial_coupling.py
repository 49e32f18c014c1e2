"""Coupled torsional and axial vibration of a crankshaft (paper 001).

A crank throw twisted by a torque also shortens or lengthens axially: its
webs bend out of the crank plane, and neighbouring throws at different
angles turn that bending into an axial displacement.  Paper 001 puts the
effect into the crank's flexibility as a torsional-axial coupling term
``C14`` and, for two cranks ``2 delta`` apart, gives it in open form (eq. 1)::

    C14 = C21 C34 cos(delta) sin(delta) / (C33 sin^2(delta) + C22 cos^2(delta))

from the single crank's flexibilities: ``C21`` (displacement along 2 per unit
axial force), ``C34`` (displacement along 3 per unit torque) and the lateral
flexibilities ``C22``, ``C33``.

The model here keeps, at every node of the crankshaft, the two degrees of
freedom the coupling joins: the axial displacement ``u`` [m] and the twist
``phi`` [rad].  Each throw is a subsystem of three nodes: the two main
journals (outer nodes, shared with the neighbouring throws) and the crank
pin (inner node, carrying the throw's mass, inertia and excitation), joined
by two half-cranks each of flexibility ``C / 2`` with
``C = [[C11, C14], [C14, C44]]``.

Dynamic stiffness (001 eq. 3): ``B(w) = K + j w C_d - w^2 M``.  A throw is
condensed to its journals (eq. 3, 4)::

    B_AA' = B_AA - B_AB B_BB^-1 B_BA,    h_A' = h_A - B_AB B_BB^-1 h_B

with ``B_BB^-1`` applied by an LU solve (never an explicit inverse), its
condition number reported.  Where ``B_BB`` is singular or ill-conditioned (the
pin resonating on fixed journals) the condensation is skipped and the
uncondensed system is solved instead: the physical problem is well posed
there, only the condensation is not.  The assembled system (eq. 5-7) is
solved for the generalised displacements; a singular assembled ``B`` (an
undamped resonance of the whole crankshaft) is refused with a clear error.

References
----------
001: Kucharski, Wittbrodt, Wojcik, A superelement for analyzing the coupling
     between crankshaft torsional and axial vibration, eq. 1-7, Fig. 1.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import scipy.linalg

from monitor.errors import ModelError
from monitor.model.engine import Engine
from monitor.model.excitation import cylinder_torque_orders
from monitor.model.inertia import mean_reciprocating_inertia
from monitor.types import ComplexArray, FloatArray

__all__ = [
    "AxialResponse",
    "AxialTorsionalCrankshaft",
    "CrankFlexibility",
    "HarmonicSolution",
    "condense",
    "constrained_coupling",
    "engine_axial_response",
    "pair_coupling",
    "pair_flexibility",
    "rotate_flexibility",
]


#: Condition number of B_BB above which the condensation is skipped.
CONDENSATION_LIMIT = 1e10
#: Condition number of the assembled B above which the problem is refused as ill-posed.
SOLVE_LIMIT = 1e14


def pair_coupling(c21: float, c34: float, c22: float, c33: float, half_angle: float) -> float:
    """Torsional-axial coupling coefficient of a crank pair (paper 001 eq. 1).

    Parameters
    ----------
    c21 : float
        Single crank: displacement along 2 per unit axial force [m/N].
    c34 : float
        Single crank: displacement along 3 per unit torque [m/(N m)].
    c22, c33 : float
        Single crank: lateral flexibilities along 2 and 3, > 0 [m/N].
    half_angle : float
        delta, half the angle between the two cranks [rad].

    Returns
    -------
    float
        C14: axial displacement per unit torque (= twist per unit axial force) [m/(N m)].
    """
    if not (c22 > 0 and c33 > 0):
        raise ModelError(f"c22 = {c22!r}, c33 = {c33!r}: expected positive lateral flexibilities [m/N]")
    s, c = math.sin(half_angle), math.cos(half_angle)
    return c21 * c34 * c * s / (c33 * s * s + c22 * c * c)


def constrained_coupling(flexibility: npt.ArrayLike, direction: float) -> float:
    """Axial-torsional coupling of a crank whose free journal is held laterally along one direction.

    Parameters
    ----------
    flexibility : array_like, shape (6, 6)
        The single crank's flexibility at its free journal (001 eq. 2, one end
        fixed), order ``(u_x, u_r, u_t, phi_x, phi_r, phi_t)``: axial, radial (in
        the crank plane), tangential, then the rotations [m/N, m/(N m), rad/(N m)].
    direction : float
        Angle of the held direction from the crank plane, about the shaft axis [rad].

    Returns
    -------
    float
        ``u_x / M_x`` with the constraint [m/(N m)].

    Notes
    -----
    The lateral reaction ``p`` along ``g = (0, cos d, sin d, 0, 0, 0)`` makes the
    constrained flexibility the Schur complement
    ``C' = C - (C g)(g^T C) / (g^T C g)``.  With ``C14 = C13 = C23 = C24 = 0`` its
    ``(1, 4)`` entry is ``-C21 C34 cos d sin d / (C22 cos^2 d + C33 sin^2 d)``:
    paper 001 eq. 1 for two cranks ``2 delta`` apart, whose common journal is held
    by its bearing along their bisector, ``delta`` from either crank plane.
    (The paper gives eq. 1 without its derivation; this is ours, and a
    two-crank beam model with the bending lever arms is not built here.)
    """
    c = np.asarray(flexibility, dtype=np.float64)
    if c.shape != (6, 6) or not np.allclose(c, c.T, rtol=1e-12, atol=0):
        raise ModelError("flexibility: expected a symmetric 6 x 6 matrix")
    g = np.array([0.0, math.cos(direction), math.sin(direction), 0.0, 0.0, 0.0])
    cg = c @ g
    denominator = float(g @ cg)
    if not denominator > 0:
        raise ModelError("flexibility: the held direction has no lateral flexibility (g^T C g <= 0)")
    constrained = c - np.outer(cg, cg) / denominator
    return float(constrained[0, 3])


def rotate_flexibility(flexibility: FloatArray, angle: float) -> FloatArray:
    """A crank's 6 x 6 flexibility turned by ``angle`` about the shaft axis into the global frame.

    Parameters
    ----------
    flexibility : ndarray, shape (6, 6)
        In the crank's frame, order ``(u_x, u_r, u_t, phi_x, phi_r, phi_t)`` [m/N, m/(N m), rad/(N m)].
    angle : float
        The crank's angle from the global reference direction [rad].

    Returns
    -------
    ndarray, shape (6, 6)
    """
    c, s = math.cos(angle), math.sin(angle)
    r = np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])
    t = np.zeros((6, 6))
    t[:3, :3] = r
    t[3:, 3:] = r
    return t @ flexibility @ t.T


def pair_flexibility(flexibility: npt.ArrayLike, half_angle: float) -> FloatArray:
    """Flexibility at the outer journal of two identical cranks ``2 delta`` apart (paper 001 Fig. 3).

    Crank 1 stands at ``+delta`` and crank 2 at ``-delta`` from their bisector. They are
    in series between a fixed journal and the loaded outer journal; the journal
    between them is held by its main bearing along the bisector. Loads at the outer
    journal pass through both cranks; the bearing's reaction acts on crank 1 only.
    As in eq. 1, the cranks' flexibilities add in series without the bending lever
    arms between them.

    Parameters
    ----------
    flexibility : array_like, shape (6, 6)
        One crank's flexibility in its own frame, order ``(u_x, u_r, u_t, phi_x,
        phi_r, phi_t)`` [m/N, m/(N m), rad/(N m)].
    half_angle : float
        delta [rad].

    Returns
    -------
    ndarray, shape (6, 6)
        Flexibility of the pair at the outer journal, in the frame of the bisector.
    """
    c = np.asarray(flexibility, dtype=np.float64)
    if c.shape != (6, 6) or not np.allclose(c, c.T, rtol=1e-12, atol=0):
        raise ModelError("flexibility: expected a symmetric 6 x 6 matrix")
    first, second = rotate_flexibility(c, half_angle), rotate_flexibility(c, -half_angle)
    g = np.array([0.0, 1.0, 0.0, 0.0, 0.0, 0.0])  # along the bisector
    first_g = first @ g
    # u = (C1 + C2) f + C1 g p with g^T C1 (f + g p) = 0 at the middle journal
    return first + second - np.outer(first_g, first_g) / float(g @ first_g)


@dataclass(frozen=True)
class CrankFlexibility:
    """Axial-torsional flexibility of one crank throw, journal to journal.

    Attributes
    ----------
    axial : float
        C11 [m/N].
    torsional : float
        C44 [rad/(N m)].
    coupling : float
        C14 [m/(N m)]; ``C11 C44 > C14^2`` (positive definite).
    """

    axial: float
    torsional: float
    coupling: float = 0.0

    def __post_init__(self) -> None:
        if not (self.axial > 0 and self.torsional > 0):
            raise ModelError(
                f"axial = {self.axial!r}, torsional = {self.torsional!r}: expected positive flexibilities"
            )
        if not self.coupling**2 < self.axial * self.torsional:
            raise ModelError(
                f"coupling = {self.coupling!r}: expected C14^2 < C11 C44 = {self.axial * self.torsional:.4g} "
                "(a flexibility matrix must be positive definite)"
            )

    @classmethod
    def from_superelement(cls, flexibility: npt.ArrayLike, held: Sequence[float]) -> CrankFlexibility:
        """The axial-torsional flexibility of a 6 x 6 crank superelement with laterals held.

        Parameters
        ----------
        flexibility : array_like, shape (6, 6)
            The crank's flexibility (001 eq. 2), order ``(u_x, u_r, u_t, phi_x,
            phi_r, phi_t)`` [m/N, m/(N m), rad/(N m)].
        held : sequence of float
            Lateral directions held by bearings, as angles from the crank plane [rad];
            bending rotations stay free.

        Returns
        -------
        CrankFlexibility
            From the ``(u_x, phi_x)`` block of the constrained flexibility (Schur
            complement); with one held direction ``delta`` its coupling is eq. 1.
        """
        c = np.asarray(flexibility, dtype=np.float64)
        if c.shape != (6, 6) or not np.allclose(c, c.T, rtol=1e-12, atol=0):
            raise ModelError("flexibility: expected a symmetric 6 x 6 matrix")
        g = np.array([[0.0, math.cos(d), math.sin(d), 0.0, 0.0, 0.0] for d in held]).T  # (6, n_held)
        if g.size:
            cg = c @ g
            c = c - cg @ np.linalg.solve(g.T @ cg, cg.T)
        return cls(axial=float(c[0, 0]), torsional=float(c[3, 3]), coupling=float(c[0, 3]))

    @property
    def matrix(self) -> FloatArray:
        """[[C11, C14], [C14, C44]]."""
        return np.array([[self.axial, self.coupling], [self.coupling, self.torsional]])


def condense(
    b: ComplexArray, h: ComplexArray, outer: Sequence[int]
) -> tuple[ComplexArray, ComplexArray, float]:
    """Condense a dynamic stiffness and its load to the outer degrees of freedom (001 eq. 3, 4).

    Parameters
    ----------
    b : ndarray, shape (n, n)
        Dynamic stiffness of the subsystem [N/m, N, N m/rad mixed].
    h : ndarray, shape (n,) or (n, m)
        Generalised loads [N, N m].
    outer : sequence of int
        Indices of the outer degrees of freedom (A); the rest are inner (B).

    Returns
    -------
    b_aa, h_a : ndarray
        ``B_AA - B_AB B_BB^-1 B_BA`` and ``h_A - B_AB B_BB^-1 h_B``.
    condition : float
        Condition number of ``B_BB``.

    Raises
    ------
    ModelError
        If ``B_BB`` is singular or its condition number exceeds ``CONDENSATION_LIMIT``.
    """
    n = b.shape[0]
    a_idx = np.asarray(outer)
    b_idx = np.setdiff1d(np.arange(n), a_idx)
    b_aa = b[np.ix_(a_idx, a_idx)]
    if b_idx.size == 0:
        return b_aa, h[a_idx], 1.0
    b_bb = b[np.ix_(b_idx, b_idx)]
    condition = float(np.linalg.cond(b_bb))
    if not math.isfinite(condition) or condition > CONDENSATION_LIMIT:
        raise ModelError(f"B_BB is ill-conditioned (condition {condition:.3g}): cannot condense here")
    lu = scipy.linalg.lu_factor(b_bb)
    b_ab = b[np.ix_(a_idx, b_idx)]
    solved = scipy.linalg.lu_solve(
        lu, np.column_stack([b[np.ix_(b_idx, a_idx)], h[b_idx].reshape(b_idx.size, -1)])
    )
    b_red = b_aa - b_ab @ solved[:, : a_idx.size]
    h_red = h[a_idx].reshape(a_idx.size, -1) - b_ab @ solved[:, a_idx.size :]
    return b_red, h_red.reshape(h[a_idx].shape), condition


@dataclass(frozen=True)
class HarmonicSolution:
    """Steady response at one frequency.

    Attributes
    ----------
    axial : ndarray, shape (n_nodes,)
        Complex axial displacement amplitudes [m].
    twist : ndarray, shape (n_nodes,)
        Complex twist amplitudes [rad].
    condition : float
        Condition number of the solved system.
    condensed : bool
        True if the throws were condensed to the journals (eq. 3-7), False if the
        uncondensed system was solved because some ``B_BB`` was ill-conditioned.
    inner_condition : float
        Largest condition number of the throws' ``B_BB``.
    """

    axial: ComplexArray
    twist: ComplexArray
    condition: float
    condensed: bool
    inner_condition: float


class AxialTorsionalCrankshaft:
    """Crankshaft with coupled axial and torsional degrees of freedom.

    Node order: journal 1, pin 1, journal 2, pin 2, ..., pin n, journal n+1, then
    any extra nodes; two degrees of freedom per node, ``(u, phi)``.

    Parameters
    ----------
    cranks : sequence of CrankFlexibility
        One per throw, journal to journal.
    pin_mass : sequence of float
        Axially moving mass at each crank pin node [kg].
    pin_inertia : sequence of float
        Polar inertia at each crank pin node [kg m^2].
    journal_mass, journal_inertia : float or sequence of float
        At each journal node [kg], [kg m^2].
    axial_support : dict of int to float, optional
        Axial springs to ground at journal nodes (the thrust bearing), by journal
        index from 0 [N/m].
    stiffness_damping : float, optional
        Damping proportional to stiffness, ``C_d = beta K`` [s].
    """

    def __init__(
        self,
        cranks: Sequence[CrankFlexibility],
        *,
        pin_mass: Sequence[float],
        pin_inertia: Sequence[float],
        journal_mass: float | Sequence[float],
        journal_inertia: float | Sequence[float],
        axial_support: dict[int, float] | None = None,
        stiffness_damping: float = 0.0,
    ) -> None:
        n = len(cranks)
        if n == 0:
            raise ModelError("a crankshaft needs at least one crank")
        if len(pin_mass) != n or len(pin_inertia) != n:
            raise ModelError(f"pin_mass and pin_inertia need one value per crank ({n})")
        jm = np.broadcast_to(np.asarray(journal_mass, dtype=np.float64), (n + 1,))
        ji = np.broadcast_to(np.asarray(journal_inertia, dtype=np.float64), (n + 1,))
        masses = np.empty(2 * n + 1)
        inertias = np.empty(2 * n + 1)
        masses[0::2], inertias[0::2] = jm, ji
        masses[1::2], inertias[1::2] = pin_mass, pin_inertia
        bad = np.flatnonzero(~(np.isfinite(masses) & np.isfinite(inertias) & (masses > 0) & (inertias > 0)))
        if bad.size:
            i = int(bad[0])
            where = f"journal {i // 2}" if i % 2 == 0 else f"pin {i // 2}"
            raise ModelError(
                f"{where}: mass = {masses[i]!r} kg, inertia = {inertias[i]!r} kg m^2: "
                "expected positive, finite values"
            )
        dof = 2 * (2 * n + 1)
        k = np.zeros((dof, dof))
        for i, crank in enumerate(cranks):
            half = np.linalg.inv(crank.matrix / 2.0)  # 2 x 2, positive definite by construction
            for a, b in ((2 * i, 2 * i + 1), (2 * i + 1, 2 * i + 2)):
                idx = [2 * a, 2 * a + 1, 2 * b, 2 * b + 1]
                k[np.ix_(idx, idx)] += np.block([[half, -half], [-half, half]])
        for journal, stiffness in (axial_support or {}).items():
            if not 0 <= journal <= n or stiffness < 0:
                raise ModelError(
                    f"axial_support: journal {journal} with {stiffness!r} N/m: expected a journal "
                    f"in 0..{n} and a non-negative stiffness"
                )
            k[4 * journal, 4 * journal] += stiffness
        self.cranks = tuple(cranks)
        self.stiffness = k
        self.mass = np.diag(np.column_stack([masses, inertias]).ravel())
        self.damping = stiffness_damping * k
        self.n_nodes = 2 * n + 1

    def dynamic_stiffness(self, frequency: float) -> ComplexArray:
        """``B(w) = K + j w C - w^2 M`` (001 eq. 3) of the whole crankshaft.

        Parameters
        ----------
        frequency : float
            w [rad/s].

        Returns
        -------
        ndarray
        """
        return np.asarray(
            self.stiffness + 1j * frequency * self.damping - frequency**2 * self.mass, dtype=np.complex128
        )

    def harmonic_response(
        self, frequency: float, *, torque: npt.ArrayLike = 0.0, axial_force: npt.ArrayLike = 0.0
    ) -> HarmonicSolution:
        """Steady response to harmonic torques and axial forces at the nodes (001 eq. 7).

        Parameters
        ----------
        frequency : float
            w [rad/s].
        torque : array_like, shape (n_nodes,)
            Complex torque amplitudes [N m].
        axial_force : array_like, shape (n_nodes,)
            Complex axial force amplitudes [N].

        Returns
        -------
        HarmonicSolution

        Raises
        ------
        ModelError
            If the assembled system is singular (undamped resonance) or its
            condition number exceeds ``SOLVE_LIMIT``.
        """
        h = np.zeros(2 * self.n_nodes, dtype=np.complex128)
        h[0::2] = np.broadcast_to(np.asarray(axial_force, dtype=np.complex128), (self.n_nodes,))
        h[1::2] = np.broadcast_to(np.asarray(torque, dtype=np.complex128), (self.n_nodes,))
        b = self.dynamic_stiffness(frequency)
        journals = np.concatenate([[2 * j, 2 * j + 1] for j in range(0, self.n_nodes, 2)])
        pins = np.setdiff1d(np.arange(2 * self.n_nodes), journals)
        inner = [
            float(np.linalg.cond(b[np.ix_(pins[2 * i : 2 * i + 2], pins[2 * i : 2 * i + 2])]))
            for i in range(len(self.cranks))
        ]
        inner_condition = max(inner)
        if inner_condition <= CONDENSATION_LIMIT:
            # eq. 3-6: condense every pin to the journals, then solve (eq. 7) and recover the pins
            b_red, h_red, _ = condense(b, h, journals.tolist())
            q = np.zeros(2 * self.n_nodes, dtype=np.complex128)
            q[journals] = self._solve(b_red, h_red)
            rhs = h[pins] - b[np.ix_(pins, journals)] @ q[journals]
            q[pins] = scipy.linalg.solve(b[np.ix_(pins, pins)], rhs)
            condition = float(np.linalg.cond(b_red))
            condensed = True
        else:
            q = self._solve(b, h)
            condition = float(np.linalg.cond(b))
            condensed = False
        return HarmonicSolution(q[0::2], q[1::2], condition, condensed, inner_condition)

    @staticmethod
    def _solve(b: ComplexArray, h: ComplexArray) -> ComplexArray:
        condition = float(np.linalg.cond(b))
        if not math.isfinite(condition) or condition > SOLVE_LIMIT:
            raise ModelError(
                f"the crankshaft's dynamic stiffness is singular (condition {condition:.3g}): an undamped "
                "resonance of the whole system; add damping or move off the natural frequency"
            )
        return np.asarray(scipy.linalg.solve(b, h), dtype=np.complex128)

    @classmethod
    def of_engine(cls, engine: Engine) -> AxialTorsionalCrankshaft:
        """The coupled crankshaft of an engine with ``[shaft_line.axial]`` data.

        Each crank's superelement flexibility has ``C11``, ``C22``, ``C33``,
        ``C21``, ``C34`` from the description and ``C44 = 1 / throw_stiffness``;
        its coupling ``C14`` is eq. 1 with ``delta`` half the angle to the next
        throw (the last throw: to the previous one).  A throw's mass and its own
        polar inertia go half to its pin and a quarter to each journal; the rod's
        crank-pin share and the mean reciprocating inertia act at the pin;
        the thrust bearing holds the driven-end journal; the flywheel's inertia
        joins that journal.  The shafting beyond the thrust bearing is left out.

        Parameters
        ----------
        engine : Engine

        Returns
        -------
        AxialTorsionalCrankshaft
        """
        if engine.vee is not None:
            raise ModelError(
                f"engine {engine.id!r} is a V engine: the coupled axial-torsional model takes one cylinder "
                "per throw (paper 001's in-line crankshaft); use the torsional model alone"
            )
        line = engine.shaft_line
        if line is None or line.axial is None:
            raise ModelError(f"engine {engine.id!r} has no [shaft_line.axial] data for the coupled model")
        axial = line.axial
        n = engine.cylinders
        throw_angles = (
            -engine.firing_angles
        )  # crank positions: cylinder c trails cylinder 1 by its firing angle
        cranks = []
        for c in range(n):
            other = c + 1 if c + 1 < n else c - 1
            delta = (
                0.5 * math.remainder(float(throw_angles[other] - throw_angles[c]), 2 * math.pi)
                if n > 1
                else 0.0
            )
            c14 = pair_coupling(
                axial.radial_per_axial_m_per_n,
                axial.tangential_per_torque_m_per_nm,
                axial.radial_flexibility_m_per_n,
                axial.tangential_flexibility_m_per_n,
                delta,
            )
            cranks.append(
                CrankFlexibility(axial.axial_flexibility_m_per_n, 1.0 / line.throw_stiffness_nm_per_rad, c14)
            )
        # a throw's own inertia is shared like its mass (half at the pin, a quarter to each journal);
        # the rod and reciprocating parts act at the pin
        inertia = (
            0.5 * line.throw_inertia_kgm2
            + engine.rotating_rod_mass * engine.crank_radius**2
            + mean_reciprocating_inertia(engine)
        )
        journal_mass = np.full(n + 1, 0.5 * axial.throw_mass_kg)
        journal_mass[[0, -1]] = 0.25 * axial.throw_mass_kg
        journal_inertia = np.full(n + 1, 0.5 * line.throw_inertia_kgm2)
        journal_inertia[[0, -1]] = 0.25 * line.throw_inertia_kgm2
        flywheel = next((e for e in line.driven_end if e.kind == "flywheel"), None)
        if flywheel is not None:
            journal_inertia[-1] += flywheel.inertia_kgm2
        return cls(
            cranks,
            pin_mass=[0.5 * axial.throw_mass_kg] * n,
            pin_inertia=[inertia] * n,
            journal_mass=journal_mass.tolist(),
            journal_inertia=journal_inertia.tolist(),
            axial_support={n: axial.thrust_bearing_stiffness_n_per_m},
            stiffness_damping=axial.stiffness_damping_s,
        )

    def modes(self) -> tuple[FloatArray, FloatArray]:
        """Coupled natural frequencies and the axial share of each mode's kinetic energy.

        Returns
        -------
        frequencies : ndarray
            Undamped natural frequencies, rigid-body modes excluded [rad/s].
        axial_share : ndarray
            Fraction of each mode's kinetic energy in axial motion, 0..1 [-].
        """
        values, vectors = scipy.linalg.eigh(self.stiffness, self.mass)
        keep = values > 1e-9 * values.max()
        shapes = vectors[:, keep]
        kinetic = np.diag(self.mass)[:, None] * shapes**2
        axial = kinetic[0::2].sum(axis=0) / kinetic.sum(axis=0)
        return np.sqrt(values[keep]), axial


@dataclass(frozen=True)
class AxialResponse:
    """Coupled response of an engine's crankshaft to its torque orders over a speed range.

    Attributes
    ----------
    speed : ndarray, shape (n_speeds,)
        [rad/s].
    orders : ndarray, shape (n_orders,)
        [-].
    axial : ndarray, shape (n_nodes, n_speeds, n_orders)
        Complex axial displacement [m].
    twist : ndarray, shape (n_nodes, n_speeds, n_orders)
        Complex twist [rad].
    """

    speed: FloatArray
    orders: FloatArray
    axial: ComplexArray
    twist: ComplexArray


def engine_axial_response(
    engine: Engine,
    speeds: npt.ArrayLike,
    *,
    load: float | str = "propeller",
    max_order: float = 12,
    model: AxialTorsionalCrankshaft | None = None,
) -> AxialResponse:
    """Axial and torsional response of the coupled crankshaft to the engine's torque orders (001 eq. 7).

    Parameters
    ----------
    engine : Engine
        With ``[shaft_line.axial]`` data.
    speeds : array_like
        Crank speeds, > 0 [rad/s].
    load : float or "propeller"
        Fraction of rated IMEP, or the propeller law (IMEP ~ speed^2) [-].
    max_order : float, optional
        Highest excitation order [-].
    model : AxialTorsionalCrankshaft, optional
        Default: :meth:`AxialTorsionalCrankshaft.of_engine`.

    Returns
    -------
    AxialResponse
    """
    shaft = model if model is not None else AxialTorsionalCrankshaft.of_engine(engine)
    w, orders, cylinder_torque = cylinder_torque_orders(engine, speeds, load=load, max_order=max_order)
    axial = np.zeros((shaft.n_nodes, w.size, orders.size), dtype=np.complex128)
    twist = np.zeros_like(axial)
    for i, speed in enumerate(w):
        for j, k in enumerate(orders):
            torque = np.zeros(shaft.n_nodes, dtype=np.complex128)
            torque[1::2] = cylinder_torque[i, :, j]
            solution = shaft.harmonic_response(float(k * speed), torque=torque)
            axial[:, i, j] = solution.axial
            twist[:, i, j] = solution.twist
    return AxialResponse(w, orders, axial, twist)
