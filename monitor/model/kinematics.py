"""Slider-crank kinematics of one cylinder: piston, connecting rod, rod centre of gravity.

The crank of radius ``R`` turns by the crank angle ``alpha`` from top dead
centre (TDC) in the direction of rotation; the connecting rod of length ``L``
(pin centre to pin centre) joins the crank pin to the piston pin (crosshead
pin on a crosshead engine); ``lambda = R / L`` is the rod ratio, ``0 <= lambda
< 1``.  The piston displacement ``x`` is measured from TDC towards the crank.

Frame of the cross-section (used for every vector here and in
:mod:`monitor.model.forces`): origin on the crankshaft axis, ``y`` along the cylinder
axis towards the cylinder head, ``x`` across it, oriented so that the crank pin
moves towards ``+x`` just after TDC.  The crank pin is at ``R (sin a, cos a)``;
the rod leans by ``beta`` with ``sin beta = lambda sin alpha``.

Exact and approximate models of the same quantity are sibling functions:
``piston_displacement`` (exact, paper 000 eq. 6) beside
``piston_displacement_approx`` (two-term, eq. 5), and so on.  Functions of
crank angle alone (``d/dalpha``) come with time-domain wrappers that take the
crank speed and, for a varying speed, the crank angular acceleration.

Numerics.  ``cos beta = sqrt(1 - lambda^2 sin^2 alpha)`` is evaluated as
``sqrt(cos^2 alpha + (1 - lambda)(1 + lambda) sin^2 alpha)``, a sum of
non-negative terms, so it keeps full relative precision as ``lambda -> 1`` at
``alpha = 90 deg`` where the direct form cancels catastrophically.  The
second derivative is written as ``cos a + lambda (cos^2 a / c^3 - sin^2 a / c)``
(``c = cos beta``), an algebraically equal form of paper 000 eq. 10 whose
terms are each bounded by ``1 / c^3``.

References
----------
000: Murawski, Kinematic of marine piston-crankshaft system, eq. 1-10.
003: Zubaydi et al., Analysis of dynamic inertia forces at main bearing of
     ship reciprocating engines, eq. 1-5.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from monitor.errors import ModelError
from monitor.types import FloatArray

__all__ = [
    "check_crank_speed",
    "check_rod_ratio",
    "cos_rod_angle",
    "piston_acceleration",
    "piston_acceleration_approx",
    "piston_displacement",
    "piston_displacement_approx",
    "piston_velocity",
    "piston_velocity_approx",
    "piston_x_derivatives",
    "piston_x_derivatives_approx",
    "rod_angle",
    "rod_angle_derivatives",
    "rod_angular_acceleration",
    "rod_angular_velocity",
    "rod_cg_acceleration",
]

ArrayLike = npt.ArrayLike

#: Largest crank speed accepted [rad/s] (about 955 000 rpm): far above any
#: engine, low enough that ``omega**2`` times any length stays finite; a larger
#: value is almost always a unit mistake (rpm or Hz given as rad/s is not).
MAX_CRANK_SPEED = 1.0e5
#: Largest crank angular acceleration accepted [rad/s^2].
MAX_CRANK_ACCELERATION = 1.0e10


def check_rod_ratio(rod_ratio: float) -> float:
    """Return ``rod_ratio`` as a float if ``0 <= rod_ratio < 1``, else raise.

    Parameters
    ----------
    rod_ratio : float
        Crank radius over connecting-rod length, lambda [-].

    Raises
    ------
    ModelError
        If the ratio is not finite or not in ``[0, 1)``: with ``lambda >= 1`` the
        rod is no longer than the crank and the mechanism locks at 90 deg.
    """
    value = float(rod_ratio)
    if not np.isfinite(value) or not 0.0 <= value < 1.0:
        raise ModelError(
            f"rod_ratio = {rod_ratio!r}: expected 0 <= rod_ratio < 1 (crank radius / "
            "connecting-rod length); with rod_ratio >= 1 the rod cannot reach the "
            "cylinder axis at 90 deg crank angle"
        )
    return value


def _angles(crank_angle: ArrayLike) -> FloatArray:
    alpha = np.asarray(crank_angle, dtype=np.float64)
    if alpha.size and not np.all(np.isfinite(alpha)):
        bad = np.flatnonzero(~np.isfinite(alpha.ravel()))
        raise ModelError(
            f"crank_angle has {bad.size} non-finite value(s) (first at flat index "
            f"{bad[0]}: {alpha.ravel()[bad[0]]!r}); expected finite angles [rad]"
        )
    return alpha


def cos_rod_angle(crank_angle: ArrayLike, rod_ratio: float) -> FloatArray:
    """Cosine of the connecting-rod angle, ``sqrt(1 - lambda^2 sin^2 alpha)``.

    Parameters
    ----------
    crank_angle : array_like
        Crank angle alpha from TDC [rad].
    rod_ratio : float
        lambda = R / L, ``0 <= lambda < 1`` [-].

    Returns
    -------
    ndarray
        cos(beta) [-], strictly positive.

    Notes
    -----
    Evaluated as ``sqrt(cos^2 a + (1 - lambda)(1 + lambda) sin^2 a)`` (paper 000
    eq. 3 rewritten without cancellation).
    """
    lam = check_rod_ratio(rod_ratio)
    alpha = _angles(crank_angle)
    s = np.sin(alpha)
    c = np.cos(alpha)
    return np.sqrt(c * c + ((1.0 - lam) * (1.0 + lam)) * (s * s))


def piston_x_derivatives(
    crank_angle: ArrayLike, crank_radius: float, rod_ratio: float
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Exact piston displacement and its first two derivatives with respect to crank angle.

    Parameters
    ----------
    crank_angle : array_like
        Crank angle alpha from TDC [rad].
    crank_radius : float
        R, half the stroke [m].
    rod_ratio : float
        lambda = R / L [-].

    Returns
    -------
    x, dx_dalpha, d2x_dalpha2 : ndarray
        Displacement from TDC towards the crank [m], [m/rad], [m/rad^2].

    Notes
    -----
    With ``c = cos beta``::

        x        = R [ 2 sin^2(a/2) + lambda sin^2 a / (1 + c) ]
        dx/da    = R sin a [ 1 + lambda cos a / c ]
        d2x/da2  = R [ cos a + lambda (cos^2 a / c^3 - sin^2 a / c) ]

    The first line is paper 000 eq. 6 with ``1 - cos`` written without
    cancellation; the third equals paper 000 eq. 10 divided by ``omega^2``.
    """
    lam = check_rod_ratio(rod_ratio)
    alpha = _angles(crank_angle)
    s = np.sin(alpha)
    co = np.cos(alpha)
    c = np.sqrt(co * co + ((1.0 - lam) * (1.0 + lam)) * (s * s))
    half = np.sin(0.5 * alpha)
    x = crank_radius * (2.0 * half * half + lam * s * s / (1.0 + c))
    dx = crank_radius * s * (1.0 + lam * co / c)
    d2x = crank_radius * (co + lam * (co * co / (c * c * c) - s * s / c))
    return x, dx, d2x


def piston_x_derivatives_approx(
    crank_angle: ArrayLike, crank_radius: float, rod_ratio: float
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Two-term (second-order) approximation of :func:`piston_x_derivatives`.

    Parameters
    ----------
    crank_angle : array_like
        Crank angle alpha from TDC [rad].
    crank_radius : float
        R [m].
    rod_ratio : float
        lambda [-].

    Returns
    -------
    x, dx_dalpha, d2x_dalpha2 : ndarray
        [m], [m/rad], [m/rad^2].

    Notes
    -----
    From ``sqrt(1 - lambda^2 sin^2 a) ~ 1 - lambda^2 sin^2 a / 2`` (paper 000
    eq. 4)::

        x       = R [ 1 - cos a + lambda sin^2 a / 2 ]     (000 eq. 5)
        dx/da   = R [ sin a + lambda sin 2a / 2 ]          (000 eq. 7)
        d2x/da2 = R [ cos a + lambda cos 2a ]              (000 eq. 9)
    """
    lam = check_rod_ratio(rod_ratio)
    alpha = _angles(crank_angle)
    s = np.sin(alpha)
    half = np.sin(0.5 * alpha)
    x = crank_radius * (2.0 * half * half + 0.5 * lam * s * s)
    dx = crank_radius * (s + 0.5 * lam * np.sin(2.0 * alpha))
    d2x = crank_radius * (np.cos(alpha) + lam * np.cos(2.0 * alpha))
    return x, dx, d2x


def piston_displacement(crank_angle: ArrayLike, crank_radius: float, rod_ratio: float) -> FloatArray:
    """Exact piston displacement from TDC towards the crank (paper 000 eq. 6).

    Parameters
    ----------
    crank_angle : array_like
        Crank angle alpha from TDC [rad].
    crank_radius : float
        R [m].
    rod_ratio : float
        lambda = R / L [-].

    Returns
    -------
    ndarray
        x [m], in ``[0, 2 R]``.

    References
    ----------
    000 eq. 2, 3, 6.
    """
    return piston_x_derivatives(crank_angle, crank_radius, rod_ratio)[0]


def piston_displacement_approx(crank_angle: ArrayLike, crank_radius: float, rod_ratio: float) -> FloatArray:
    """Two-term approximate piston displacement (paper 000 eq. 5).

    Parameters
    ----------
    crank_angle : array_like
        Crank angle alpha from TDC [rad].
    crank_radius : float
        R [m].
    rod_ratio : float
        lambda [-].

    Returns
    -------
    ndarray
        x [m].
    """
    return piston_x_derivatives_approx(crank_angle, crank_radius, rod_ratio)[0]


def check_crank_speed(
    crank_speed: ArrayLike, crank_acceleration: ArrayLike = 0.0
) -> tuple[FloatArray, FloatArray]:
    """Crank speed and angular acceleration as arrays, refused if not finite or absurd.

    Parameters
    ----------
    crank_speed : array_like
        omega; magnitude at most ``MAX_CRANK_SPEED`` [rad/s].
    crank_acceleration : array_like, optional
        domega/dt; magnitude at most ``MAX_CRANK_ACCELERATION`` [rad/s^2].

    Returns
    -------
    omega, omega_dot : ndarray

    Raises
    ------
    ModelError
        Naming the value and the limit.
    """
    omega = np.asarray(crank_speed, dtype=np.float64)
    omega_dot = np.asarray(crank_acceleration, dtype=np.float64)
    checks = (
        ("crank_speed", omega, MAX_CRANK_SPEED, "rad/s"),
        ("crank_acceleration", omega_dot, MAX_CRANK_ACCELERATION, "rad/s^2"),
    )
    for name, value, limit, unit in checks:
        if value.size and not np.all(np.abs(value) <= limit):
            worst = float(value.ravel()[np.flatnonzero(~(np.abs(value.ravel()) <= limit))[0]])
            raise ModelError(
                f"{name} = {worst!r}: expected a finite value with magnitude <= {limit:g} {unit}"
            )
    return omega, omega_dot


def piston_velocity(
    crank_angle: ArrayLike, crank_speed: ArrayLike, crank_radius: float, rod_ratio: float
) -> FloatArray:
    """Exact piston velocity ``dx/dt = dx/dalpha * omega`` (paper 000 eq. 8).

    Parameters
    ----------
    crank_angle : array_like
        Crank angle alpha [rad].
    crank_speed : array_like
        omega = dalpha/dt, broadcast against ``crank_angle`` [rad/s].
    crank_radius : float
        R [m].
    rod_ratio : float
        lambda [-].

    Returns
    -------
    ndarray
        Piston velocity towards the crank [m/s].
    """
    omega, _ = check_crank_speed(crank_speed, 0.0)
    return piston_x_derivatives(crank_angle, crank_radius, rod_ratio)[1] * omega


def piston_velocity_approx(
    crank_angle: ArrayLike, crank_speed: ArrayLike, crank_radius: float, rod_ratio: float
) -> FloatArray:
    """Two-term approximate piston velocity (paper 000 eq. 7).

    Parameters
    ----------
    crank_angle : array_like
        Crank angle alpha [rad].
    crank_speed : array_like
        omega [rad/s].
    crank_radius : float
        R [m].
    rod_ratio : float
        lambda [-].

    Returns
    -------
    ndarray
        [m/s].
    """
    omega, _ = check_crank_speed(crank_speed, 0.0)
    return piston_x_derivatives_approx(crank_angle, crank_radius, rod_ratio)[1] * omega


def piston_acceleration(
    crank_angle: ArrayLike,
    crank_speed: ArrayLike,
    crank_radius: float,
    rod_ratio: float,
    crank_acceleration: ArrayLike = 0.0,
) -> FloatArray:
    """Exact piston acceleration, for a constant or a varying crank speed.

    Parameters
    ----------
    crank_angle : array_like
        Crank angle alpha [rad].
    crank_speed : array_like
        omega = dalpha/dt [rad/s].
    crank_radius : float
        R [m].
    rod_ratio : float
        lambda [-].
    crank_acceleration : array_like, optional
        domega/dt; 0 for a constant speed [rad/s^2].

    Returns
    -------
    ndarray
        Piston acceleration towards the crank [m/s^2].

    Notes
    -----
    ``a = d2x/dalpha2 omega^2 + dx/dalpha domega/dt``; with a constant speed
    this is paper 000 eq. 10.
    """
    omega, omega_dot = check_crank_speed(crank_speed, crank_acceleration)
    _, dx, d2x = piston_x_derivatives(crank_angle, crank_radius, rod_ratio)
    return d2x * omega * omega + dx * omega_dot


def piston_acceleration_approx(
    crank_angle: ArrayLike,
    crank_speed: ArrayLike,
    crank_radius: float,
    rod_ratio: float,
    crank_acceleration: ArrayLike = 0.0,
) -> FloatArray:
    """Two-term approximate piston acceleration (paper 000 eq. 9, plus the domega/dt term).

    Parameters
    ----------
    crank_angle : array_like
        Crank angle alpha [rad].
    crank_speed : array_like
        omega [rad/s].
    crank_radius : float
        R [m].
    rod_ratio : float
        lambda [-].
    crank_acceleration : array_like, optional
        domega/dt [rad/s^2].

    Returns
    -------
    ndarray
        [m/s^2].
    """
    omega, omega_dot = check_crank_speed(crank_speed, crank_acceleration)
    _, dx, d2x = piston_x_derivatives_approx(crank_angle, crank_radius, rod_ratio)
    return d2x * omega * omega + dx * omega_dot


def rod_angle(crank_angle: ArrayLike, rod_ratio: float) -> FloatArray:
    """Connecting-rod angle beta, ``sin beta = lambda sin alpha`` (paper 000 eq. 3).

    Parameters
    ----------
    crank_angle : array_like
        Crank angle alpha [rad].
    rod_ratio : float
        lambda [-].

    Returns
    -------
    ndarray
        beta [rad], in ``(-pi/2, pi/2)``, positive when the crank pin is on the ``+x`` side.
    """
    lam = check_rod_ratio(rod_ratio)
    alpha = _angles(crank_angle)
    return np.arctan2(lam * np.sin(alpha), cos_rod_angle(alpha, lam))


def rod_angle_derivatives(
    crank_angle: ArrayLike, rod_ratio: float
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Rod angle and its first two derivatives with respect to crank angle.

    Parameters
    ----------
    crank_angle : array_like
        Crank angle alpha [rad].
    rod_ratio : float
        lambda [-].

    Returns
    -------
    beta, dbeta_dalpha, d2beta_dalpha2 : ndarray
        [rad], [-], [1/rad].

    Notes
    -----
    Differentiating ``sin beta = lambda sin alpha``::

        dbeta/da   = lambda cos a / c
        d2beta/da2 = -lambda (1 - lambda^2) sin a / c^3
    """
    lam = check_rod_ratio(rod_ratio)
    alpha = _angles(crank_angle)
    s = np.sin(alpha)
    co = np.cos(alpha)
    c = np.sqrt(co * co + ((1.0 - lam) * (1.0 + lam)) * (s * s))
    beta = np.arctan2(lam * s, c)
    return beta, lam * co / c, -lam * ((1.0 - lam) * (1.0 + lam)) * s / (c * c * c)


def rod_angular_velocity(crank_angle: ArrayLike, crank_speed: ArrayLike, rod_ratio: float) -> FloatArray:
    """Angular velocity of the connecting rod, ``dbeta/dt`` [rad/s].

    Parameters
    ----------
    crank_angle : array_like
        Crank angle alpha [rad].
    crank_speed : array_like
        omega [rad/s].
    rod_ratio : float
        lambda [-].

    Returns
    -------
    ndarray
        dbeta/dt [rad/s] (counter-clockwise positive in the section frame).
    """
    omega, _ = check_crank_speed(crank_speed, 0.0)
    return rod_angle_derivatives(crank_angle, rod_ratio)[1] * omega


def rod_angular_acceleration(
    crank_angle: ArrayLike,
    crank_speed: ArrayLike,
    rod_ratio: float,
    crank_acceleration: ArrayLike = 0.0,
) -> FloatArray:
    """Angular acceleration of the connecting rod, ``d2beta/dt2`` [rad/s^2].

    Parameters
    ----------
    crank_angle : array_like
        Crank angle alpha [rad].
    crank_speed : array_like
        omega [rad/s].
    rod_ratio : float
        lambda [-].
    crank_acceleration : array_like, optional
        domega/dt [rad/s^2].

    Returns
    -------
    ndarray
        d2beta/dt2 [rad/s^2].
    """
    omega, omega_dot = check_crank_speed(crank_speed, crank_acceleration)
    _, d1, d2 = rod_angle_derivatives(crank_angle, rod_ratio)
    return d2 * omega * omega + d1 * omega_dot


def rod_cg_acceleration(
    crank_angle: ArrayLike,
    crank_speed: ArrayLike,
    crank_radius: float,
    rod_ratio: float,
    cg_fraction: float,
    crank_acceleration: ArrayLike = 0.0,
) -> tuple[FloatArray, FloatArray]:
    """Acceleration of the connecting rod's centre of gravity in the section frame.

    Parameters
    ----------
    crank_angle : array_like
        Crank angle alpha [rad].
    crank_speed : array_like
        omega [rad/s].
    crank_radius : float
        R [m].
    rod_ratio : float
        lambda [-].
    cg_fraction : float
        Distance of the centre of gravity from the piston-pin centre over the
        rod length, ``0 <= k <= 1`` (0 at the piston pin, 1 at the crank pin) [-].
    crank_acceleration : array_like, optional
        domega/dt [rad/s^2].

    Returns
    -------
    ax, ay : ndarray
        Components across and along the cylinder axis [m/s^2].

    Notes
    -----
    The rod is rigid, so the acceleration of a point on it is the affine
    combination of its end points' accelerations:
    ``a_G = (1 - k) a_A + k a_B`` with the piston pin ``a_A = (0, -d2x/dt2)`` and
    the crank pin ``a_B = -R omega^2 (sin a, cos a) + R domega/dt (cos a, -sin a)``.
    Paper 003 eq. 2-5 gives the same vector by differentiating
    ``r2 e^{i theta2} + r_d e^{i theta3}`` (the tests check the two agree).
    """
    if not 0.0 <= cg_fraction <= 1.0:
        raise ModelError(
            f"cg_fraction = {cg_fraction!r}: expected 0 <= cg_fraction <= 1 (distance of "
            "the rod's centre of gravity from the piston pin over the rod length)"
        )
    omega, omega_dot = check_crank_speed(crank_speed, crank_acceleration)
    alpha = _angles(crank_angle)
    a_piston = piston_acceleration(alpha, omega, crank_radius, rod_ratio, omega_dot)
    s = np.sin(alpha)
    co = np.cos(alpha)
    w2 = omega * omega
    bx = crank_radius * (-w2 * s + omega_dot * co)
    by = crank_radius * (-w2 * co - omega_dot * s)
    k = cg_fraction
    return k * bx, (1.0 - k) * (-a_piston) + k * by
