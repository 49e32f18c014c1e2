"""Crank-train kinematics, inertia and the forces a cylinder's throw puts on its main bearings.

Along the cylinder's axis (:func:`throw_vertical_force`, the vertical of an in-line engine) and
across it (:func:`throw_across_force`), both from Newton-Euler on piston, rod and throw; on a V
engine each cylinder's two components are turned into the engine's vertical by its bank's lean
(:func:`cylinder_vertical_forces`). On articulated rods each cylinder's terms come from the linkage
solved as rigid bodies (:func:`cylinder_rows`, :mod:`validation.simulator.linkage`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from validation.simulator.engine import SimEngine
from validation.simulator.linkage import linkage_terms
from validation.simulator.shared import AMBIENT_PRESSURE, FloatArray


@dataclass(frozen=True)
class SliderCrank:
    """Positions and their derivatives in the crank angle of one cylinder's crank train.

    ``y`` is measured along the cylinder axis from the crank axis towards the head, ``x`` across
    it; ``phi`` is the rod's angle to the cylinder axis. Primes are derivatives in the crank angle.

    Attributes
    ----------
    piston, piston_1, piston_2 : ndarray
        Piston pin height y_p and its first and second derivatives [m], [m/rad], [m/rad^2].
    rod_x_1, rod_x_2, rod_y_1, rod_y_2 : ndarray
        Derivatives of the rod centre of gravity's position [m/rad], [m/rad^2].
    rod_angle_1, rod_angle_2 : ndarray
        Derivatives of the rod angle [-], [1/rad].
    """

    piston: FloatArray
    piston_1: FloatArray
    piston_2: FloatArray
    rod_x_1: FloatArray
    rod_x_2: FloatArray
    rod_y_1: FloatArray
    rod_y_2: FloatArray
    rod_angle_1: FloatArray
    rod_angle_2: FloatArray


def slider_crank(
    crank_angle: npt.ArrayLike, *, crank_radius: float, rod_length: float, rod_cg_from_pin: float
) -> SliderCrank:
    """Exact slider-crank kinematics.

    Parameters
    ----------
    crank_angle : array_like
        The cylinder's crank angle from its TDC, psi [rad].
    crank_radius : float
        R [m].
    rod_length : float
        L, pin centre to pin centre [m].
    rod_cg_from_pin : float
        a, the rod's centre of gravity from the piston pin [m].

    Returns
    -------
    SliderCrank

    Notes
    -----
    ``sin phi = lambda sin psi`` (``lambda = R / L``); crank pin at ``(R sin psi, R cos psi)``,
    piston pin at ``(0, y_p)`` with ``y_p = R cos psi + L cos phi``, rod centre of gravity at
    ``((a / L) R sin psi, R cos psi + (L - a) cos phi)``.  ``phi' = lambda cos psi / cos phi`` and
    ``phi'' = lambda (cos psi sin phi phi' - sin psi cos phi) / cos^2 phi``.
    """
    psi = np.asarray(crank_angle, dtype=np.float64)
    r, length, a = crank_radius, rod_length, rod_cg_from_pin
    lam = r / length
    s, c = np.sin(psi), np.cos(psi)
    sin_phi = lam * s
    cos_phi = np.sqrt(1 - sin_phi**2)
    phi_1 = lam * c / cos_phi
    phi_2 = lam * (c * sin_phi * phi_1 - s * cos_phi) / cos_phi**2
    bend = cos_phi * phi_1**2 + sin_phi * phi_2  # d^2(cos phi)/dpsi^2 with the sign flipped
    return SliderCrank(
        piston=r * c + length * cos_phi,
        piston_1=-r * s - length * sin_phi * phi_1,
        piston_2=-r * c - length * bend,
        rod_x_1=(a / length) * r * c,
        rod_x_2=-(a / length) * r * s,
        rod_y_1=-r * s - (length - a) * sin_phi * phi_1,
        rod_y_2=-r * c - (length - a) * bend,
        rod_angle_1=phi_1,
        rod_angle_2=phi_2,
    )


def engine_kinematics(engine: SimEngine, psi: npt.ArrayLike) -> SliderCrank:
    return slider_crank(
        psi,
        crank_radius=engine.crank_radius,
        rod_length=engine.rod_length,
        rod_cg_from_pin=engine.rod_cg_from_pin,
    )


def equivalent_inertia(engine: SimEngine, crank_angle: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
    """One cylinder's piston and rod as an inertia on the crank, and its derivative.

    Parameters
    ----------
    engine : SimEngine
    crank_angle : array_like
        The cylinder's crank angle from its TDC [rad].

    Returns
    -------
    inertia, derivative : ndarray
        ``J_c`` [kg m^2] and ``dJ_c/dpsi`` [kg m^2/rad].

    Notes
    -----
    From the kinetic energy ``T = J_c omega^2 / 2`` of piston and rod (exact, no two-mass split):
    ``J_c = m_p y_p'^2 + m_r (x_g'^2 + y_g'^2) + I_r phi'^2``. On articulated rods ``crank_angle``
    has a row per cylinder, and a slave's bodies are its piston and slave rod
    (:func:`cylinder_rows`).
    """
    if engine.rods == "articulated":
        rows = cylinder_rows(engine, crank_angle)
        return rows.inertia, rows.inertia_1
    k = engine_kinematics(engine, crank_angle)
    mp, mr, ir = engine.piston_mass, engine.rod_mass, engine.rod_inertia
    inertia = mp * k.piston_1**2 + mr * (k.rod_x_1**2 + k.rod_y_1**2) + ir * k.rod_angle_1**2
    derivative = 2 * (
        mp * k.piston_1 * k.piston_2
        + mr * (k.rod_x_1 * k.rod_x_2 + k.rod_y_1 * k.rod_y_2)
        + ir * k.rod_angle_1 * k.rod_angle_2
    )
    return inertia, derivative


def piston_arm(engine: SimEngine, crank_angle: npt.ArrayLike) -> FloatArray:
    """Each piston's travel from its TDC per crank angle, the gas torque per gas force [m].

    Parameters
    ----------
    engine : SimEngine
    crank_angle : array_like
        The cylinder's crank angle from its TDC [rad]; on articulated rods a row per cylinder.

    Returns
    -------
    ndarray
        ``-dy_p/dpsi`` [m/rad].
    """
    if engine.rods == "articulated":
        return cylinder_rows(engine, crank_angle).arm
    return np.asarray(-engine_kinematics(engine, crank_angle).piston_1)


def inertia_force_coefficients(engine: SimEngine, psi: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
    """``K2, K1`` with ``sum_i m_i ddot(y_i) = K2 omega^2 + K1 omega_dot``, piston, rod, throw [kg m]."""
    k = engine_kinematics(engine, psi)
    psi = np.asarray(psi, dtype=np.float64)
    # throw's mass x radius towards the pin (on a V each of its two cylinders carries half)
    net = (engine.crank_unbalance - engine.counterweight) * engine.unbalance_share
    k2 = engine.piston_mass * k.piston_2 + engine.rod_mass * k.rod_y_2 - net * np.cos(psi)
    k1 = engine.piston_mass * k.piston_1 + engine.rod_mass * k.rod_y_1 - net * np.sin(psi)
    return k2, k1


def throw_vertical_force(
    engine: SimEngine,
    crank_angle: npt.ArrayLike,
    pressure: npt.ArrayLike,
    speed: npt.ArrayLike,
    acceleration: npt.ArrayLike,
) -> FloatArray:
    """Vertical force of one throw on its main bearings, upwards (towards the head) positive.

    Parameters
    ----------
    engine : SimEngine
    crank_angle : array_like
        The cylinder's crank angle from its TDC [rad].
    pressure : array_like
        Its cylinder pressure, absolute [Pa].
    speed : array_like
        Crank speed [rad/s].
    acceleration : array_like
        Crank angular acceleration [rad/s^2].

    Returns
    -------
    ndarray
        [N].

    Notes
    -----
    Newton's second law along the cylinder axis for piston, rod and throw, each a free body: the
    rod passes the piston's load plus its own inertia to the crank pin, and the throw passes
    that plus its own to the bearings, so ``F = -(p - p_amb) A - (m_p ddot(y_p) + m_r ddot(y_g)
    + u ddot(cos psi))`` with ``ddot(y) = y'' omega^2 + y' omega_dot`` and the throw's net
    unbalance ``u`` (crank pin and webs less counterweights) [kg m].
    """
    k2, k1 = inertia_force_coefficients(engine, crank_angle)
    w = np.asarray(speed, dtype=np.float64)
    gas = (np.asarray(pressure, dtype=np.float64) - AMBIENT_PRESSURE) * engine.piston_area
    return np.asarray(-gas - (k2 * w**2 + k1 * np.asarray(acceleration, dtype=np.float64)))


def across_force_coefficients(
    engine: SimEngine, psi: npt.ArrayLike
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """``G, K2, K1`` of the across-axis force on the bearings, ``G (p - p_amb) A + K2 w^2 + K1 w_dot``.

    Parameters
    ----------
    engine : SimEngine
    psi : array_like
        The cylinder's crank angle from its TDC [rad].

    Returns
    -------
    tuple of ndarray
        [-], [kg m], [kg m].

    Notes
    -----
    Newton-Euler on each free body, ``x`` across the axis, ``y`` along it. Piston: the liner's side
    force ``N`` and the rod's force ``F_rp`` balance (``N = -F_rp,x``), ``F_rp,y = m_p ddot(y_p) + F_g``
    with the gas force ``F_g = (p - p_amb) A``. Rod: ``F_cr = m_r a_G + F_rp`` (crank pin on rod), and
    its moments about its centre of gravity ``I_r ddot(phi) = L sin(phi) F_rp,y + L cos(phi) F_rp,x + b m_r
    (sin(phi) ddot(y_G) + cos(phi) ddot(x_G))`` with ``b = L - a``, so
    ``N = tan(phi) F_rp,y + (b m_r (sin(phi) ddot(y_G) + cos(phi) ddot(x_G)) - I_r ddot(phi))
    / (L cos(phi))``.
    Throw: the bearings carry ``-F_cr - u ddot(r_u)``, ``u`` its share of the net unbalance at the pin
    ``(sin psi, cos psi)``; across the axis ``N - m_r ddot(x_G) - u ddot(sin psi)``: the liner's side force
    itself acts on the frame, not on a bearing.
    """
    k = engine_kinematics(engine, psi)
    angle = np.asarray(psi, dtype=np.float64)
    lam = engine.crank_radius / engine.rod_length
    sin_phi = lam * np.sin(angle)
    cos_phi = np.sqrt(1 - sin_phi**2)
    tan_phi = sin_phi / cos_phi
    mp, mr, ir = engine.piston_mass, engine.rod_mass, engine.rod_inertia
    b, length = engine.rod_length - engine.rod_cg_from_pin, engine.rod_length
    u = (engine.crank_unbalance - engine.counterweight) * engine.unbalance_share

    def part(piston: FloatArray, gx: FloatArray, gy: FloatArray, rod: FloatArray) -> FloatArray:
        moment = (b * mr * (sin_phi * gy + cos_phi * gx) - ir * rod) / (length * cos_phi)
        return np.asarray(tan_phi * mp * piston + moment - mr * gx)

    k2 = part(k.piston_2, k.rod_x_2, k.rod_y_2, k.rod_angle_2) + u * np.sin(angle)
    k1 = part(k.piston_1, k.rod_x_1, k.rod_y_1, k.rod_angle_1) - u * np.cos(angle)
    return np.asarray(tan_phi), k2, k1


def throw_across_force(
    engine: SimEngine,
    crank_angle: npt.ArrayLike,
    pressure: npt.ArrayLike,
    speed: npt.ArrayLike,
    acceleration: npt.ArrayLike,
) -> FloatArray:
    """Force of one cylinder's throw on its main bearings across the cylinder's axis.

    Parameters
    ----------
    engine : SimEngine
    crank_angle : array_like
        The cylinder's crank angle from its TDC [rad].
    pressure : array_like
        Its cylinder pressure, absolute [Pa].
    speed : array_like
        Crank speed [rad/s].
    acceleration : array_like
        Crank angular acceleration [rad/s^2].

    Returns
    -------
    ndarray
        Towards ``+x``, where the crank pin goes after its TDC [N].

    Notes
    -----
    :func:`across_force_coefficients` derives it.
    """
    g, k2, k1 = across_force_coefficients(engine, crank_angle)
    gas = (np.asarray(pressure, dtype=np.float64) - AMBIENT_PRESSURE) * engine.piston_area
    w = np.asarray(speed, dtype=np.float64)
    return np.asarray(g * gas + k2 * w**2 + k1 * np.asarray(acceleration, dtype=np.float64))


def vertical_force_coefficients(
    engine: SimEngine, psi: npt.ArrayLike, *, horizontal: bool = False
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """``G, K2, K1`` of each cylinder's force on its bearings along the engine's vertical.

    Parameters
    ----------
    engine : SimEngine
    psi : array_like, shape (n, ...)
        Each cylinder's crank angle from its TDC [rad].
    horizontal : bool, optional
        Along the engine's horizontal (``+x``) instead: ``sin(lambda) F_along + cos(lambda) F_across``.

    Returns
    -------
    tuple of ndarray
        The vertical force is ``G (p - p_amb) A + K2 omega^2 + K1 omega_dot`` [-], [kg m], [kg m].

    Notes
    -----
    A cylinder whose axis leans ``lambda`` from the vertical towards ``+x`` has its axis along
    ``(sin lambda, cos lambda)`` and its ``+x`` across it along ``(cos lambda, -sin lambda)``, so
    the vertical is ``cos(lambda) F_along - sin(lambda) F_across``. Articulated rods:
    :func:`cylinder_rows`.
    """
    if engine.rods == "articulated":
        rows = cylinder_rows(engine, psi)
        return rows.horizontal if horizontal else rows.vertical
    angle = np.asarray(psi, dtype=np.float64)
    lean = engine.cylinder_leans.reshape((-1,) + (1,) * (angle.ndim - 1))
    c, s = np.cos(lean), np.sin(lean)
    a2, a1 = inertia_force_coefficients(engine, angle)
    g, k2, k1 = across_force_coefficients(engine, angle)
    if horizontal:
        return np.asarray(-s + c * g), np.asarray(-s * a2 + c * k2), np.asarray(-s * a1 + c * k1)
    return np.asarray(-c - s * g), np.asarray(-c * a2 - s * k2), np.asarray(-c * a1 - s * k1)


def cylinder_vertical_forces(
    engine: SimEngine,
    crank_angle: npt.ArrayLike,
    pressure: npt.ArrayLike,
    speed: npt.ArrayLike,
    acceleration: npt.ArrayLike,
) -> FloatArray:
    """Each cylinder's force on its throw's main bearings along the engine's vertical, upwards.

    Parameters
    ----------
    engine : SimEngine
    crank_angle : array_like, shape (n, ...)
        Each cylinder's crank angle from its TDC [rad].
    pressure : array_like, shape (n, ...)
        Absolute [Pa].
    speed, acceleration : array_like
        [rad/s], [rad/s^2].

    Returns
    -------
    ndarray, shape (n, ...)
        [N]; an in-line engine's is :func:`throw_vertical_force`.
    """
    if not engine.is_vee:
        return throw_vertical_force(engine, crank_angle, pressure, speed, acceleration)
    g, k2, k1 = vertical_force_coefficients(engine, crank_angle)
    gas = (np.asarray(pressure, dtype=np.float64) - AMBIENT_PRESSURE) * engine.piston_area
    w = np.asarray(speed, dtype=np.float64)
    return np.asarray(g * gas + k2 * w**2 + k1 * np.asarray(acceleration, dtype=np.float64))


def bearing_split(
    cylinder_positions: npt.ArrayLike,
    bearing_positions: npt.ArrayLike,
    throw_bearings: list[tuple[int, int]],
) -> FloatArray:
    """Share of each throw's force carried by each main bearing (statically determinate throws).

    Parameters
    ----------
    cylinder_positions : array_like, shape (n,)
        Axial position of each throw's force [m].
    bearing_positions : array_like, shape (b,)
        Axial position of each main bearing [m].
    throw_bearings : list of (int, int)
        The two bearings (1-based) each throw sits between.

    Returns
    -------
    ndarray, shape (b, n)
        ``F_bearings = share @ F_throws`` [-].

    Raises
    ------
    ValueError
        If a throw does not lie between its two bearings.

    Notes
    -----
    Each throw is a beam simply supported on its two bearings: moments about one bearing give the
    other's reaction, ``F_2 = F (z_c - z_1) / (z_2 - z_1)`` and ``F_1 = F - F_2``, so every column
    sums to 1 (force equilibrium) and ``sum_b z_b share[b, c] = z_c`` (moment equilibrium).
    """
    zc = np.asarray(cylinder_positions, dtype=np.float64)
    zb = np.asarray(bearing_positions, dtype=np.float64)
    if len(throw_bearings) != zc.size:
        raise ValueError(f"throw_bearings has {len(throw_bearings)} pairs: expected {zc.size}, one per throw")
    share = np.zeros((zb.size, zc.size))
    for c, (b1, b2) in enumerate(throw_bearings):
        z1, z2 = zb[b1 - 1], zb[b2 - 1]
        if not min(z1, z2) <= zc[c] <= max(z1, z2) or z1 == z2:
            raise ValueError(
                f"throw {c + 1} at {zc[c]:.4g} m: expected between its bearings {b1} and {b2} "
                f"({z1:.4g}, {z2:.4g} m)"
            )
        w2 = (zc[c] - z1) / (z2 - z1)
        share[b1 - 1, c] += 1 - w2
        share[b2 - 1, c] += w2
    return share


@dataclass(frozen=True)
class CylinderRows:
    """An articulated engine's terms by cylinder, each at its own crank angle from its own TDC.

    Attributes
    ----------
    inertia, inertia_1, arm : ndarray, shape (n, ...)
        As :class:`LinkageTerms`' [kg m^2], [kg m^2/rad], [m].
    vertical, horizontal : tuple of ndarray, shape (n, ...) each
        ``G, K2, K1`` of the cylinder's force on its throw's bearings along the engine's vertical
        (upwards) and horizontal (``+x``), its share of the throw's unbalance included: the force is
        ``G (p - p_amb) A + K2 omega^2 + K1 omega_dot`` [-], [kg m], [kg m].
    """

    inertia: FloatArray
    inertia_1: FloatArray
    arm: FloatArray
    vertical: tuple[FloatArray, FloatArray, FloatArray]
    horizontal: tuple[FloatArray, FloatArray, FloatArray]


def cylinder_rows(engine: SimEngine, psi: npt.ArrayLike) -> CylinderRows:
    """Each cylinder's terms on an articulated V engine.

    Parameters
    ----------
    engine : SimEngine
        ``rods == "articulated"``.
    psi : array_like, shape (n, ...)
        Each cylinder's crank angle from its own TDC [rad] (a slave's TDC lies
        :attr:`SimEngine.trailing_offset` after its master's).

    Returns
    -------
    CylinderRows

    Notes
    -----
    The forces come in the master's frame, whose axis leans ``-g/2`` from the engine's vertical
    (the leading bank's), so the vertical is ``cos(g/2) F_y + sin(g/2) F_x`` and the horizontal
    ``-sin(g/2) F_y + cos(g/2) F_x``.
    """
    angle = np.asarray(psi, dtype=np.float64)
    slaves = engine.slaves.reshape((-1,) + (1,) * (angle.ndim - 1))
    t = angle + np.where(slaves, engine.trailing_offset, 0.0)
    terms = linkage_terms(engine.linkage, t)

    def pick(values: FloatArray) -> FloatArray:  # (2 kinds, n, ...) -> each row's own kind
        return np.asarray(np.where(slaves, values[1], values[0]))

    u = (engine.crank_unbalance - engine.counterweight) * engine.unbalance_share
    sin_t, cos_t = np.sin(t), np.cos(t)
    gas = [pick(terms.gas[:, i]) for i in (0, 1)]
    k2 = [pick(terms.k2[:, 0]) + u * sin_t, pick(terms.k2[:, 1]) + u * cos_t]
    k1 = [pick(terms.k1[:, 0]) - u * cos_t, pick(terms.k1[:, 1]) + u * sin_t]
    c, s = np.cos(engine.bank_angle / 2), np.sin(engine.bank_angle / 2)

    def turned(xy: list[FloatArray]) -> tuple[FloatArray, FloatArray]:
        return np.asarray(c * xy[1] + s * xy[0]), np.asarray(-s * xy[1] + c * xy[0])

    (gv, gh), (k2v, k2h), (k1v, k1h) = turned(gas), turned(k2), turned(k1)
    return CylinderRows(
        inertia=pick(terms.inertia),
        inertia_1=pick(terms.inertia_1),
        arm=pick(terms.arm),
        vertical=(gv, k2v, k1v),
        horizontal=(gh, k2h, k1h),
    )
