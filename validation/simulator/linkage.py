"""The articulated (master-and-slave) rods of a V engine, solved as a linkage of rigid bodies.

Written apart from the product's closed form: the positions come from Newton's method on the loop
equations, the velocities and accelerations in the crank angle from their linear systems, and the
forces from Newton-Euler on every body at once with Lagrange multipliers (no two-force members, no
two-mass rods: each rod is a rigid body with its own mass, centre of gravity and moment of inertia).

Frame: the master cylinder's (``y`` along its axis towards its head, ``x`` across it), the crank pin
at ``R (sin t, cos t)``, ``t`` the crank angle from the master's TDC. Unknowns of the loop equations:
the master rod's angle ``f`` (its axis from crank pin to piston pin along ``(-sin f, cos f)``), the
master piston pin's height ``y``, the slave rod's direction ``h`` (from knuckle pin to slave piston pin
along ``(sin h, cos h)``) and the slave piston pin's distance ``s`` from the crankshaft axis along
the slave bore ``w = (sin g, cos g)``, ``g`` the bank angle. The knuckle pin sits at ``r`` from the
crank pin's centre, at the angle ``d`` from the master rod's axis towards the slave bank:
``K = C + r (sin(d - f), cos(d - f))``. Loop equations::

    R sin t - L sin f = 0,                      R cos t + L cos f - y = 0,
    R sin t + r sin(d - f) + l sin h - s sin g = 0,
    R cos t + r cos(d - f) + l cos h - s cos g = 0.

Forces: maximal coordinates (master piston pin, master rod's centre of gravity and angle, slave
rod's, slave piston pin), ten constraints (two bores, four pins), ``M q'' = Q + Phi_q^T lambda`` at a
crank speed ``omega`` and acceleration ``omega_dot`` (``q'' = dq/dt omega_dot + d2q/dt2 omega^2``).
The crank pin's multiplier is the crank pin's force on the master rod; the throw passes its opposite,
plus its share of the throw's unbalance, to the main bearings. Everything is linear in the two gas
forces, ``omega^2`` and ``omega_dot``, and in the bodies' masses, so each cylinder's rows hold its own
piston's gas force and its own bodies' inertia (the master's piston and rod, the slave's piston and
rod), and the two rows sum to the whole.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from validation.simulator.shared import FloatArray

_NEWTON_STEPS = 40
_SETTLED = 1e-13  # a Newton step this small (in rad and in units of the crank radius) has settled


@dataclass(frozen=True)
class Linkage:
    """An articulated rod pair's geometry and masses (SI units, angles in rad).

    Attributes
    ----------
    crank_radius, rod_length, rod_cg_from_pin : float
        ``R``, the master rod's ``L`` and its centre of gravity from the piston pin [m].
    knuckle_radius, knuckle_angle : float
        ``r`` [m] and ``d`` [rad] (module docstring).
    slave_rod_length, slave_rod_cg_from_pin : float
        ``l`` and the slave rod's centre of gravity from its piston pin [m].
    bank_angle : float
        ``g`` [rad].
    piston_mass, rod_mass, rod_inertia : float
        Each piston [kg]; the master rod's mass [kg] and moment of inertia about its centre of gravity
        [kg m^2].
    slave_rod_mass, slave_rod_inertia : float
        [kg], [kg m^2].
    """

    crank_radius: float
    rod_length: float
    rod_cg_from_pin: float
    knuckle_radius: float
    knuckle_angle: float
    slave_rod_length: float
    slave_rod_cg_from_pin: float
    bank_angle: float
    piston_mass: float = 0.0
    rod_mass: float = 0.0
    rod_inertia: float = 0.0
    slave_rod_mass: float = 0.0
    slave_rod_inertia: float = 0.0


@dataclass(frozen=True)
class LinkageMotion:
    """The linkage's unknowns and their first two derivatives in the crank angle, shape of ``t`` each.

    Attributes
    ----------
    z, z_1, z_2 : ndarray, shape (4, ...)
        ``(f, y, h, s)`` [rad, m, rad, m] and their derivatives [per rad, per rad^2].
    """

    crank_angle: FloatArray
    z: FloatArray
    z_1: FloatArray
    z_2: FloatArray


def _jacobian(k: Linkage, z: FloatArray) -> FloatArray:
    """d(loop equations)/d(f, y, h, s), shape (..., 4, 4)."""
    f, _, h, _ = z
    length, r, d, rod, g = k.rod_length, k.knuckle_radius, k.knuckle_angle, k.slave_rod_length, k.bank_angle
    zero, one = np.zeros_like(f), np.ones_like(f)
    rows = [
        [-length * np.cos(f), zero, zero, zero],
        [-length * np.sin(f), -one, zero, zero],
        [-r * np.cos(d - f), zero, rod * np.cos(h), -np.sin(g) * one],
        [r * np.sin(d - f), zero, -rod * np.sin(h), -np.cos(g) * one],
    ]
    return np.moveaxis(np.array(rows), (0, 1), (-2, -1))


def _residual(k: Linkage, t: FloatArray, z: FloatArray) -> FloatArray:
    f, y, h, s = z
    radius, length, r, d = k.crank_radius, k.rod_length, k.knuckle_radius, k.knuckle_angle
    rod, g = k.slave_rod_length, k.bank_angle
    return np.array(
        [
            radius * np.sin(t) - length * np.sin(f),
            radius * np.cos(t) + length * np.cos(f) - y,
            radius * np.sin(t) + r * np.sin(d - f) + rod * np.sin(h) - s * np.sin(g),
            radius * np.cos(t) + r * np.cos(d - f) + rod * np.cos(h) - s * np.cos(g),
        ]
    )


def _solve(a: FloatArray, b: FloatArray) -> FloatArray:
    """Solve ``a x = b`` at every point: ``a`` (..., n, n), ``b`` (n, ...) -> (n, ...)."""
    x = np.asarray(np.linalg.solve(a, np.moveaxis(b, 0, -1)[..., None])[..., 0], dtype=np.float64)
    return np.moveaxis(x, -1, 0)


def linkage_motion(k: Linkage, crank_angle: npt.ArrayLike) -> LinkageMotion:
    """Solve the loop equations at each crank angle, and their derivatives in it.

    Parameters
    ----------
    k : Linkage
    crank_angle : array_like
        ``t``, from the master's TDC [rad].

    Returns
    -------
    LinkageMotion

    Raises
    ------
    ValueError
        If Newton's method does not settle (a linkage that cannot be assembled).
    """
    t = np.asarray(crank_angle, dtype=np.float64)
    radius, g = k.crank_radius, k.bank_angle
    # a start on the right branch: the rods as if both hung on the crank pin
    f = np.arcsin(np.clip(radius * np.sin(t) / k.rod_length, -1, 1))
    z = np.array(
        [
            f,
            radius * np.cos(t) + k.rod_length,
            np.full_like(t, g),
            radius * np.cos(t - g) + k.slave_rod_length,
        ]
    )
    for _ in range(_NEWTON_STEPS):
        step = _solve(_jacobian(k, z), -_residual(k, t, z))
        z = z + step
        if np.all(np.abs(step) <= _SETTLED * np.array([1, radius, 1, radius]).reshape((4,) + (1,) * t.ndim)):
            break
    else:
        raise ValueError("the articulated linkage did not settle: check its lengths and angles")
    jac = _jacobian(k, z)
    f, _, h, _ = z
    rate = np.array([radius * np.cos(t), -radius * np.sin(t), radius * np.cos(t), -radius * np.sin(t)])
    z_1 = _solve(jac, -rate)
    f1, _, h1, _ = z_1
    r, d, rod, length = k.knuckle_radius, k.knuckle_angle, k.slave_rod_length, k.rod_length
    # second derivative of each loop equation less its part in z'' (sin x'' = cos x x'' - sin x x'^2)
    rest = np.array(
        [
            -radius * np.sin(t) + length * np.sin(f) * f1**2,
            -radius * np.cos(t) - length * np.cos(f) * f1**2,
            -radius * np.sin(t) - r * np.sin(d - f) * f1**2 - rod * np.sin(h) * h1**2,
            -radius * np.cos(t) - r * np.cos(d - f) * f1**2 - rod * np.cos(h) * h1**2,
        ]
    )
    return LinkageMotion(t, z, z_1, _solve(jac, -rest))


@functools.lru_cache(maxsize=64)
def slave_dead_centres(k: Linkage) -> tuple[float, float]:
    """The crank angles of the slave piston's top and bottom dead centres, from the master's TDC [rad].

    Where ``ds/dt = 0``: the highest and lowest of a 1 deg sweep, refined by the secant method on
    ``ds/dt`` to round-off.

    Parameters
    ----------
    k : Linkage

    Returns
    -------
    top, bottom : float
        ``top`` in ``[0, 2 pi)``.
    """
    sweep = np.radians(np.arange(360.0))
    s = linkage_motion(k, sweep).z[3]
    out = []
    for start in (sweep[np.argmax(s)], sweep[np.argmin(s)]):
        a, b = start - 0.01, start + 0.01
        fa, fb = (float(linkage_motion(k, x).z_1[3]) for x in (a, b))
        for _ in range(60):
            if fb == fa or abs(b - a) < 1e-15:
                break
            a, b, fa = b, b - fb * (b - a) / (fb - fa), fb
            fb = float(linkage_motion(k, b).z_1[3])
        out.append(float(np.mod(b, 2 * np.pi)))
    return out[0], out[1]


def slave_travel(k: Linkage, psi: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
    """The slave piston's travel from its top dead centre, and its derivative.

    Parameters
    ----------
    k : Linkage
    psi : array_like
        The crank angle from the slave's TDC (:func:`slave_dead_centres`) [rad].

    Returns
    -------
    travel, rate : ndarray
        ``s_TDC - s`` [m] and its derivative in the crank angle [m/rad].
    """
    top = slave_dead_centres(k)[0]
    motion = linkage_motion(k, np.asarray(psi, dtype=np.float64) + top)
    s_top = float(linkage_motion(k, top).z[3])
    return s_top - motion.z[3], -motion.z_1[3]


@dataclass(frozen=True)
class LinkageTerms:
    """What each of the pair's cylinders puts on the crank, at each crank angle ``t``.

    The first axis is the cylinder: 0 the master, 1 the slave. Forces are on the crank pin (so on the
    main bearings), in the master's frame, ``[x, y]`` on the second axis: ``gas`` per newton of that
    cylinder's gas force ``(p - p_amb) A``, ``k2`` per ``omega^2``, ``k1`` per ``omega_dot``.

    Attributes
    ----------
    inertia, inertia_1 : ndarray, shape (2, ...)
        The cylinder's moving bodies as an inertia on the crank, ``2 T / omega^2`` [kg m^2], and its
        derivative in ``t`` [kg m^2/rad].
    arm : ndarray, shape (2, ...)
        Its piston's travel from its top dead centre per crank angle: gas torque over gas force [m].
    gas : ndarray, shape (2, 2, ...)
        [-].
    k2, k1 : ndarray, shape (2, 2, ...)
        [kg m].
    """

    inertia: FloatArray
    inertia_1: FloatArray
    arm: FloatArray
    gas: FloatArray
    k2: FloatArray
    k1: FloatArray


def _unit(angle: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
    """``(sin a, cos a)`` and its derivative ``(cos a, -sin a)`` in ``a``, each shape (2, ...)."""
    a = np.asarray(angle, dtype=np.float64)
    return np.array([np.sin(a), np.cos(a)]), np.array([np.cos(a), -np.sin(a)])


def linkage_terms(k: Linkage, crank_angle: npt.ArrayLike) -> LinkageTerms:
    """Each cylinder's inertia, gas-torque arm and forces on the crank pin (module docstring).

    Parameters
    ----------
    k : Linkage
    crank_angle : array_like
        ``t``, from the master's TDC [rad].

    Returns
    -------
    LinkageTerms
        Without the throw's own unbalance (the caller adds its share).
    """
    motion = linkage_motion(k, crank_angle)
    t = motion.crank_angle
    f, _, h, _ = motion.z
    f1, y1, h1, s1 = motion.z_1
    f2, y2, h2, s2 = motion.z_2
    a, b = k.rod_cg_from_pin, k.slave_rod_cg_from_pin
    zero = np.zeros_like(t)
    # the master rod's axis e_m = (-sin f, cos f), the slave rod's e_s = (sin h, cos h), and their
    # derivatives in their angles (a second derivative of a unit vector is minus itself)
    em_f = np.array([-np.cos(f), -np.sin(f)])
    em_ff = np.array([np.sin(f), -np.cos(f)])
    es, es_h = _unit(h)
    es_hh = -es
    w, v = _unit(k.bank_angle)  # the slave's bore and its normal towards +x
    pin_1 = np.array([zero, y1])
    pin_2 = np.array([zero, y2])
    slave_1 = np.multiply.outer(w, s1)
    slave_2 = np.multiply.outer(w, s2)
    gm_1 = pin_1 - a * em_f * f1
    gm_2 = pin_2 - a * (em_ff * f1**2 + em_f * f2)
    gs_1 = slave_1 - b * es_h * h1
    gs_2 = slave_2 - b * (es_hh * h1**2 + es_h * h2)
    mp, mr, ir, ms, i_s = k.piston_mass, k.rod_mass, k.rod_inertia, k.slave_rod_mass, k.slave_rod_inertia
    master_inertia = mp * y1**2 + mr * (gm_1**2).sum(axis=0) + ir * f1**2
    slave_inertia = mp * s1**2 + ms * (gs_1**2).sum(axis=0) + i_s * h1**2
    master_rate = 2 * (mp * y1 * y2 + mr * (gm_1 * gm_2).sum(axis=0) + ir * f1 * f2)
    slave_rate = 2 * (mp * s1 * s2 + ms * (gs_1 * gs_2).sum(axis=0) + i_s * h1 * h2)

    # constraint Jacobian in maximal coordinates [Px, Py, Gmx, Gmy, f, Gsx, Gsy, h, Sx, Sy]
    shape = t.shape
    jac = np.zeros((*shape, 10, 10))
    eye = np.eye(2)
    jac[..., 0, 0] = 1.0  # the master bore: P_x = 0
    jac[..., 1:3, 0:2] = -eye  # master small end: G_m + a e_m - P = 0
    jac[..., 1:3, 2:4] = eye
    jac[..., 1:3, 4] = np.moveaxis(a * em_f, 0, -1)
    jac[..., 3:5, 2:4] = eye  # master big end: G_m - (L - a) e_m - C(t) = 0
    jac[..., 3:5, 4] = np.moveaxis(-(k.rod_length - a) * em_f, 0, -1)
    knuckle_f = np.array([-np.cos(k.knuckle_angle - f), np.sin(k.knuckle_angle - f)])
    jac[..., 5:7, 2:4] = eye  # knuckle: master big end + r (sin(d-f), cos(d-f)) = slave big end
    jac[..., 5:7, 4] = np.moveaxis(-(k.rod_length - a) * em_f + k.knuckle_radius * knuckle_f, 0, -1)
    jac[..., 5:7, 5:7] = -eye
    jac[..., 5:7, 7] = np.moveaxis((k.slave_rod_length - b) * es_h, 0, -1)
    jac[..., 7:9, 5:7] = eye  # slave small end: G_s + b e_s - S = 0
    jac[..., 7:9, 7] = np.moveaxis(b * es_h, 0, -1)
    jac[..., 7:9, 8:10] = -eye
    jac[..., 9, 8:10] = v  # the slave bore: S . v = 0

    def rates(
        pin: FloatArray, gm: FloatArray, rod_f: FloatArray, gs: FloatArray, rod_h: FloatArray, sl: FloatArray
    ) -> FloatArray:
        return np.concatenate([pin, gm, rod_f[None], gs, rod_h[None], sl])

    q1 = rates(pin_1, gm_1, f1, gs_1, h1, slave_1)
    q2 = rates(pin_2, gm_2, f2, gs_2, h2, slave_2)
    master_mass = np.array([mp, mp, mr, mr, ir, 0, 0, 0, 0, 0], dtype=np.float64)
    slave_mass = np.array([0, 0, 0, 0, 0, ms, ms, i_s, mp, mp], dtype=np.float64)
    gas_master = np.array([0, -1, 0, 0, 0, 0, 0, 0, 0, 0], dtype=np.float64)  # a unit gas force
    gas_slave = np.concatenate([np.zeros(8), -w])  # on each piston, towards the crank

    def along(vector: FloatArray) -> FloatArray:  # (10,) -> (10, 1, ...) against q1, q2
        return vector.reshape((10, *(1,) * t.ndim))

    parts = [-along(gas_master), -along(gas_slave)]
    parts += [along(mass) * q for q in (q2, q1) for mass in (master_mass, slave_mass)]
    rhs = np.stack([np.broadcast_to(p, (10, *shape)) for p in parts], axis=-1)  # M q'' - Q by part
    multipliers = np.asarray(
        np.linalg.solve(np.swapaxes(jac, -1, -2), np.moveaxis(rhs, 0, -2)), dtype=np.float64
    )
    on_pin = -np.moveaxis(multipliers[..., 3:5, :], (-2, -1), (0, 1))  # (2 xy, 6, ...): on the crank pin
    return LinkageTerms(
        inertia=np.array([master_inertia, slave_inertia]),
        inertia_1=np.array([master_rate, slave_rate]),
        arm=np.array([-y1, -s1]),
        gas=np.moveaxis(on_pin[:, 0:2], 1, 0),
        k2=np.moveaxis(on_pin[:, 2:4], 1, 0),
        k1=np.moveaxis(on_pin[:, 4:6], 1, 0),
    )
