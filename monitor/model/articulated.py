"""The articulated (master-and-slave) connecting rod of a V engine: the slave piston's exact motion.

On a V engine with articulated rods one bank's rod (the master) runs from the crank pin to its piston
as a plain slider-crank (:mod:`monitor.model.kinematics`); the other bank's rod (the slave) is pinned
to the master rod at the knuckle pin, beside the crank pin, and not to the crank pin itself. So the
slave piston does not move as a slider-crank at the bank angle: its stroke is not ``2 R`` (longer
where the knuckle angle exceeds the bank angle, shorter where it falls short) and its top dead centre
is not where the crank points along its bore.

Geometry, in the frame of :mod:`monitor.model.kinematics` (origin on the crankshaft axis, ``y`` along
the master cylinder's axis towards its head, ``x`` across it, the crank pin at ``R (sin a, cos a)``,
``a`` the crank angle from the master's TDC in the direction of rotation):

- the master rod, of length ``L``, from the crank pin ``C`` to the master piston pin on the ``y``
  axis; its unit vector ``u = (-R sin a / L, cos b)`` with ``sin b = lambda sin a``;
- the knuckle pin ``K = C + r (u cos d + n sin d)``, at distance ``r`` from the crank pin's centre and
  at the fixed angle ``d`` from the master rod's axis towards the slave bank (``n = (u_y, -u_x)``, the
  rod's normal towards ``+x``);
- the slave cylinder's axis through the crankshaft axis at the bank angle ``g`` from the master's,
  towards ``+x``: ``w = (sin g, cos g)``, its normal ``v = (cos g, -sin g)``;
- the slave rod, of length ``l``, from ``K`` to the slave piston pin ``S = s w`` (``s`` its distance
  from the crankshaft axis): ``|S - K| = l`` gives, in closed form,

      s = K . w + sqrt(l^2 - (K . v)^2).

Its derivatives in the crank angle follow by the chain rule from ``K' = C' + r (u' cos d + n' sin d)``
(``u' = (-lambda cos a, -sin b b')``, ``b' = lambda cos a / cos b``), exactly: with ``p = K . w``,
``q = K . v`` and ``h = sqrt(l^2 - q^2)``, ``s' = p' - q q' / h`` and ``s'' = p'' - (q'^2 + q q'') / h
- q^2 q'^2 / h^3``. The slave's top and bottom dead centres are the crank angles where ``s' = 0``
(found by Newton's method on ``s'`` with ``s''``, from the highest and lowest of a sweep): its
displacement from its own TDC is ``s_TDC - s``.

The loads a force on the slave piston puts on the crank (massless rods, frictionless pins; the
piston's axial force ``F`` positive towards the crank, as :mod:`monitor.model.forces` signs it): the
slave rod is a two-force member along ``e = (S - K) / l``, so its compression is ``T = F / (e . w)``
and the slave's bore takes ``N_s = -T (e . v)`` across it. The master rod is then held at three pins:
the knuckle (``-T e``), the master piston pin, which takes a force across the master's bore alone
(``Q x``, its piston carrying no axial force of the slave's), and the crank pin ``C``. Its moments
about the crank pin give ``Q = -T ((K - C) x e) / (L cos b)`` (``a x b = a_x b_y - a_y b_x``), the
master bore takes ``Q`` too, and the force on the crank pin is ``G = Q x - T e``; its moment about the
crankshaft axis in the direction of rotation (from ``y`` towards ``x``), ``C_y G_x - C_x G_y``, is the
torque, which virtual work gives independently as ``-F ds/da`` (the tests compare the two).

The slave's moving masses (:meth:`ArticulatedRod.slave_train_forces`), at a constant crank speed
``omega``: the slave rod split as :mod:`monitor.model.forces`' two-mass rod, its piston-pin share with
the slave piston in ``m_s``, its knuckle-pin share ``m_k`` moving with the knuckle pin (the moment of
inertia the split implies, ``m k (1 - k) l^2``; a rigid rod's own would add a small inertia torque).
The slave piston's inertia along its bore towards the crank is ``m_s s'' omega^2`` (d'Alembert's
``-m a`` with ``a = s'' omega^2 w``), added to its gas force as the axial force ``F``; the knuckle
share's, ``-m_k K'' omega^2``, acts on the master rod at the knuckle pin, which carries it to the
crank pin and the master bore as it carries the slave rod's ``-T e`` (the moments about the crank pin
above, with the sum of the two in place of ``-T e``). What shakes the engine is their sum,
``-(m_s s'' w + m_k K'') omega^2``. At a constant speed the inertia torque is the kinetic energy's
``-dE/da`` with ``E = omega^2 (m_s s'^2 + m_k |K'|^2) / 2`` (the tests check it).

With ``r = 0`` the slave rod hangs on the crank pin: the slave is then a slider-crank of rod ``l`` at
the bank angle (side-by-side or fork-and-blade rods), the limit the tests check.

References
----------
000: Murawski, Kinematic of marine piston-crankshaft system (the slider-crank, eq. 1-10), whose
     derivation this extends to the knuckle pin; the slave's closed form is derived here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np
import numpy.typing as npt

from monitor.errors import ModelError
from monitor.model.kinematics import check_crank_speed, check_rod_ratio, cos_rod_angle
from monitor.types import FloatArray

__all__ = ["ArticulatedRod", "SlaveLoads", "SlaveStroke", "SlaveTrainForces"]

_NEWTON_STEPS = 50  # at most, for a dead centre; it converges quadratically in a handful
_SETTLED_RAD = 1e-10  # a Newton step this small has settled: the next is below round-off [rad]
_SWEEP = 720  # crank angles swept for the dead centres' first guesses (every half degree)


@dataclass(frozen=True)
class SlaveStroke:
    """The slave piston's dead centres and stroke.

    Attributes
    ----------
    tdc_angle : float
        The crank angle of the slave's top dead centre, from the master's TDC [rad], in [0, 2 pi).
    bdc_angle : float
        Of its bottom dead centre [rad], in [0, 2 pi).
    tdc_offset : float
        ``tdc_angle`` less the bank angle: how far the articulation moves the slave's TDC from where
        the crank points along its bore [rad].
    stroke : float
        ``s_TDC - s_BDC`` [m] (``2 R`` for a slider-crank).
    top : float
        ``s_TDC``, the slave piston pin's distance from the crankshaft axis at TDC [m].
    """

    tdc_angle: float
    bdc_angle: float
    tdc_offset: float
    stroke: float
    top: float


@dataclass(frozen=True)
class SlaveLoads:
    """What an axial force on the slave piston puts on the crank, in the master's frame (module
    docstring). Every array has the shape of the crank angle and the force broadcast together.

    Attributes
    ----------
    pin_force_x, pin_force_y : ndarray
        The force of the master rod on the crank pin, across and along the master's bore [N].
    torque : ndarray
        Its moment about the crankshaft axis, in the direction of rotation [N m].
    slave_rod_force : ndarray
        The slave rod's compression [N].
    slave_guide_force : ndarray
        The slave bore's force on the slave piston, along the slave's ``x`` (``v``) [N].
    master_guide_force : ndarray
        The master bore's force on the master piston along ``x`` that the slave's force calls for [N].
    """

    pin_force_x: FloatArray
    pin_force_y: FloatArray
    torque: FloatArray
    slave_rod_force: FloatArray
    slave_guide_force: FloatArray
    master_guide_force: FloatArray


@dataclass(frozen=True)
class SlaveTrainForces:
    """The slave's gas and inertia loads on the crank (:meth:`ArticulatedRod.slave_train_forces`), in
    the master's frame, over the crank angle from the master's TDC.

    Attributes
    ----------
    gas_force : ndarray
        On the slave piston, towards the crank [N].
    axial_force : ndarray
        Gas, reciprocating inertia and weight on the slave piston along its bore, towards the crank [N].
    loads : SlaveLoads
        On the crank pin (with the knuckle share's inertia), its torque and the bores' forces.
    inertia_force_x, inertia_force_y : ndarray
        The slave's moving masses' inertia on the engine (``-m a``), what its free forces add up [N].
    """

    gas_force: FloatArray
    axial_force: FloatArray
    loads: SlaveLoads
    inertia_force_x: FloatArray
    inertia_force_y: FloatArray


@dataclass(frozen=True)
class ArticulatedRod:
    """A master rod and the slave rod pinned to it (module docstring).

    Attributes
    ----------
    crank_radius : float
        ``R`` [m].
    master_length : float
        ``L``, crank pin to master piston pin [m].
    knuckle_radius : float
        ``r``, crank pin centre to knuckle pin centre [m] (0: the slave rod on the crank pin).
    knuckle_angle : float
        ``d``, the knuckle pin's angle from the master rod's axis towards the slave bank [rad].
    slave_length : float
        ``l``, knuckle pin to slave piston pin [m].
    bank_angle : float
        ``g``, the slave cylinder's axis from the master's, in the direction of rotation [rad].
    """

    crank_radius: float
    master_length: float
    knuckle_radius: float
    knuckle_angle: float
    slave_length: float
    bank_angle: float

    def __post_init__(self) -> None:
        lengths = (self.crank_radius, self.master_length, self.slave_length)
        if not all(math.isfinite(x) and x > 0 for x in lengths) or not (
            math.isfinite(self.knuckle_radius) and 0.0 <= self.knuckle_radius < self.master_length
        ):
            raise ModelError(
                f"articulated rod: crank_radius = {self.crank_radius!r}, master_length = "
                f"{self.master_length!r}, slave_length = {self.slave_length!r}, knuckle_radius = "
                f"{self.knuckle_radius!r}: expected positive lengths and 0 <= knuckle_radius < master_length"
            )
        if not (math.isfinite(self.bank_angle) and 0.0 < self.bank_angle < math.pi):
            raise ModelError(f"bank_angle = {self.bank_angle!r} rad: expected between 0 and pi")
        if not math.isfinite(self.knuckle_angle):
            raise ModelError(f"knuckle_angle = {self.knuckle_angle!r} rad: expected a finite angle")
        check_rod_ratio(self.crank_radius / self.master_length)
        # the slave rod must reach its bore at every crank angle: |K . v| < l everywhere
        reach = float(np.max(np.abs(self._knuckle(np.linspace(0.0, 2 * math.pi, 721))[0] @ self._normal)))
        if reach >= self.slave_length:
            raise ModelError(
                f"articulated rod: the knuckle pin strays {reach:.4g} m from the slave bore's axis, the "
                f"slave rod is {self.slave_length:.4g} m: it cannot reach its piston at every crank angle"
            )

    @property
    def _axis(self) -> FloatArray:
        """The slave cylinder's axis ``w`` (unit)."""
        return np.array([math.sin(self.bank_angle), math.cos(self.bank_angle)])

    @property
    def _normal(self) -> FloatArray:
        """Its normal ``v`` (unit)."""
        return np.array([math.cos(self.bank_angle), -math.sin(self.bank_angle)])

    def _knuckle(self, crank_angle: npt.ArrayLike) -> tuple[FloatArray, FloatArray, FloatArray]:
        """The knuckle pin's position and its first two derivatives in the crank angle, shape (n, 2)."""
        a = np.atleast_1d(np.asarray(crank_angle, dtype=np.float64))
        lam = self.crank_radius / self.master_length
        sin_a, cos_a = np.sin(a), np.cos(a)
        cos_b = cos_rod_angle(a, lam)
        sin_b = lam * sin_a
        db = lam * cos_a / cos_b  # b'
        d2b = lam * (-sin_a * cos_b + cos_a * sin_b * db) / cos_b**2  # b''
        radius = self.crank_radius
        crank = radius * np.stack([sin_a, cos_a], axis=-1)
        crank1 = radius * np.stack([cos_a, -sin_a], axis=-1)
        crank2 = -crank
        u = np.stack([-sin_b, cos_b], axis=-1)
        u1 = np.stack([-lam * cos_a, -sin_b * db], axis=-1)
        u2 = np.stack([lam * sin_a, -(cos_b * db**2 + sin_b * d2b)], axis=-1)

        def turned(vector: FloatArray) -> FloatArray:
            # the rod's direction turned by d towards +x: u cos d + n sin d, n = (u_y, -u_x)
            normal = np.stack([vector[:, 1], -vector[:, 0]], axis=-1)
            return np.asarray(vector * math.cos(self.knuckle_angle) + normal * math.sin(self.knuckle_angle))

        r = self.knuckle_radius
        return crank + r * turned(u), crank1 + r * turned(u1), crank2 + r * turned(u2)

    def slave_position(self, crank_angle: npt.ArrayLike) -> tuple[FloatArray, FloatArray, FloatArray]:
        """The slave piston pin's distance from the crankshaft axis, and its derivatives.

        Parameters
        ----------
        crank_angle : array_like
            From the master's TDC [rad].

        Returns
        -------
        s, ds, d2s : ndarray
            ``s`` [m], ``ds/da`` [m/rad] and ``d2s/da2`` [m/rad^2], shaped as ``crank_angle``.
        """
        shape = np.shape(crank_angle)
        s, ds, d2s = self._place(self._knuckle(np.ravel(crank_angle)))
        return s.reshape(shape), ds.reshape(shape), d2s.reshape(shape)

    def _place(self, knuckle: tuple[FloatArray, FloatArray, FloatArray]) -> tuple[FloatArray, ...]:
        """The slave's place and its two derivatives from the knuckle pin's (module docstring)."""
        k, k1, k2 = knuckle
        w, v = self._axis, self._normal
        p, p1, p2 = k @ w, k1 @ w, k2 @ w
        q, q1, q2 = k @ v, k1 @ v, k2 @ v
        h = np.sqrt((self.slave_length - q) * (self.slave_length + q))
        return p + h, p1 - q * q1 / h, p2 - (q1**2 + q * q2) / h - q**2 * q1**2 / h**3

    def slave_loads(self, crank_angle: npt.ArrayLike, axial_force: npt.ArrayLike) -> SlaveLoads:
        """The loads an axial force on the slave piston puts on the crank (module docstring).

        Parameters
        ----------
        crank_angle : array_like
            From the master's TDC [rad].
        axial_force : array_like
            On the slave piston along its bore, positive towards the crank (gas and inertia), broadcast
            with the crank angle [N].

        Returns
        -------
        SlaveLoads
        """
        a, force_at = np.broadcast_arrays(
            np.asarray(crank_angle, dtype=np.float64), np.asarray(axial_force, dtype=np.float64)
        )
        flat = np.atleast_1d(a).ravel()
        knuckle = self._knuckle(flat)
        return self._loads(flat, knuckle, self._place(knuckle)[0], force_at.ravel(), 0.0, a.shape)

    def _loads(
        self,
        flat: FloatArray,
        knuckle: tuple[FloatArray, FloatArray, FloatArray],
        place: FloatArray,
        force: FloatArray,
        at_knuckle: FloatArray | float,
        shape: tuple[int, ...],
    ) -> SlaveLoads:
        """The slave's axial ``force`` and a force ``at_knuckle`` (shape (n, 2), on the master rod at
        the knuckle pin) carried to the crank pin (module docstring)."""
        w, v = self._axis, self._normal
        rod = (place[:, None] * w - knuckle[0]) / self.slave_length  # e, knuckle to slave pin (unit)
        compression = force / (rod @ w)
        on_master = -compression[:, None] * rod + at_knuckle  # on the master rod at the knuckle pin
        lam = self.crank_radius / self.master_length
        crank = self.crank_radius * np.stack([np.sin(flat), np.cos(flat)], axis=-1)
        lever = knuckle[0] - crank  # K - C
        height = self.master_length * cos_rod_angle(flat, lam)  # (P - C)_y
        master = (lever[:, 0] * on_master[:, 1] - lever[:, 1] * on_master[:, 0]) / height
        pin = on_master.copy()
        pin[:, 0] += master
        torque = crank[:, 1] * pin[:, 0] - crank[:, 0] * pin[:, 1]  # the crank turns from y towards x
        return SlaveLoads(
            pin_force_x=pin[:, 0].reshape(shape),
            pin_force_y=pin[:, 1].reshape(shape),
            torque=torque.reshape(shape),
            slave_rod_force=compression.reshape(shape),
            slave_guide_force=(-compression * (rod @ v)).reshape(shape),
            master_guide_force=master.reshape(shape),
        )

    def slave_train_forces(
        self,
        crank_angle: npt.ArrayLike,
        *,
        crank_speed: float,
        gas_force: npt.ArrayLike,
        reciprocating_mass: float,
        knuckle_mass: float,
        gravity: float,
    ) -> SlaveTrainForces:
        """The slave's gas and inertia loads on the crank at a constant crank speed (module docstring).

        Parameters
        ----------
        crank_angle : array_like, 1-D
            From the master's TDC [rad].
        crank_speed : float
            omega [rad/s].
        gas_force : array_like
            On the slave piston, positive towards the crank, broadcast with the crank angle [N].
        reciprocating_mass : float
            The slave piston and its rod's piston-pin share [kg].
        knuckle_mass : float
            The slave rod's knuckle-pin share [kg].
        gravity : float
            [m/s^2]: the reciprocating weight along the slave's bore and the knuckle share's along the
            master's, as :mod:`monitor.model.forces` takes each cylinder's weights; 0 leaves them out.

        Returns
        -------
        SlaveTrainForces
        """
        flat = np.asarray(crank_angle, dtype=np.float64)
        if flat.ndim != 1:
            raise ModelError(f"crank angle of shape {flat.shape}: expected one dimension")
        omega, _ = check_crank_speed(crank_speed)
        if not all(math.isfinite(m) and m >= 0 for m in (reciprocating_mass, knuckle_mass)):
            raise ModelError(
                f"slave masses {reciprocating_mass!r} and {knuckle_mass!r} kg: expected finite and >= 0"
            )
        gas = np.broadcast_to(np.asarray(gas_force, dtype=np.float64), flat.shape)
        knuckle = self._knuckle(flat)
        place, _, d2s = self._place(knuckle)
        w2 = omega * omega
        # d'Alembert: the piston's inertia towards the crank is m s'' omega^2 (s'' < 0 at TDC pulls it away)
        axial = gas + reciprocating_mass * (d2s * w2 + gravity)
        at_knuckle = -knuckle_mass * (knuckle[2] * w2 + np.array([0.0, gravity]))
        loads = self._loads(flat, knuckle, place, axial, at_knuckle, flat.shape)
        inertia = -reciprocating_mass * w2 * d2s[:, None] * self._axis - knuckle_mass * w2 * knuckle[2]
        return SlaveTrainForces(
            gas_force=np.array(gas),
            axial_force=axial,
            loads=loads,
            inertia_force_x=inertia[:, 0],
            inertia_force_y=inertia[:, 1],
        )

    def slave_inertia(
        self, crank_angle: npt.ArrayLike, *, reciprocating_mass: float, knuckle_mass: float
    ) -> FloatArray:
        """The slave's moving masses' inertia about the crankshaft, ``m_s s'^2 + m_k |K'|^2`` (module
        docstring): their kinetic energy is ``omega^2 / 2`` times it.

        Parameters
        ----------
        crank_angle : array_like
            From the master's TDC [rad].
        reciprocating_mass, knuckle_mass : float
            [kg], as :meth:`slave_train_forces` takes them.

        Returns
        -------
        ndarray
            [kg m^2], shaped as ``crank_angle``.
        """
        flat = np.ravel(np.asarray(crank_angle, dtype=np.float64))
        knuckle = self._knuckle(flat)
        ds = self._place(knuckle)[1]
        inertia = reciprocating_mass * ds**2 + knuckle_mass * np.sum(knuckle[1] ** 2, axis=-1)
        return np.asarray(inertia.reshape(np.shape(crank_angle)))

    def slave_displacement(self, crank_angle: npt.ArrayLike) -> FloatArray:
        """The slave piston's displacement from its own TDC towards the crank [m].

        Parameters
        ----------
        crank_angle : array_like
            From the master's TDC [rad].

        Returns
        -------
        ndarray
            ``s_TDC - s`` [m], 0 at the slave's TDC, its stroke at its BDC.
        """
        return np.asarray(self._stroke.top - self.slave_position(crank_angle)[0])

    def stroke(self) -> SlaveStroke:
        """The slave's dead centres and stroke (module docstring).

        Returns
        -------
        SlaveStroke

        Raises
        ------
        ModelError
            If Newton's method does not settle on a dead centre (a linkage that folds).
        """
        return self._stroke

    @cached_property
    def _stroke(self) -> SlaveStroke:
        """:meth:`stroke`, found once (a displacement asked for at every step of an integration)."""
        # Newton's method from the highest and lowest of a sweep of the crank angle: a linkage near
        # folding has more than one extremum, and the slider-crank's guess can settle on the wrong one
        sweep = np.linspace(0.0, 2 * math.pi, _SWEEP, endpoint=False)
        place = self.slave_position(sweep)[0]
        tdc = self._dead_centre(float(sweep[int(np.argmax(place))]))
        bdc = self._dead_centre(float(sweep[int(np.argmin(place))]))
        top = float(self.slave_position(tdc)[0])
        bottom = float(self.slave_position(bdc)[0])
        return SlaveStroke(
            tdc_angle=tdc % (2 * math.pi),
            bdc_angle=bdc % (2 * math.pi),
            tdc_offset=math.remainder(tdc - self.bank_angle, 2 * math.pi),
            stroke=top - bottom,
            top=top,
        )

    def _dead_centre(self, start: float) -> float:
        """The crank angle where ``ds/da = 0`` nearest ``start`` (Newton's method on ``s'`` with ``s''``)."""
        angle = start
        for _ in range(_NEWTON_STEPS):
            _, ds, d2s = self.slave_position(angle)
            step = float(ds) / float(d2s)
            angle -= step
            # converged: one step more is quadratically below round-off (a fixed 1e-15 rad was below
            # the spacing of doubles near 2 pi, where the steps dither without ever getting under it)
            if abs(step) < _SETTLED_RAD:
                _, ds, d2s = self.slave_position(angle)
                return angle - float(ds) / float(d2s)
        raise ModelError(
            f"articulated rod: no dead centre of the slave near {math.degrees(start):.1f} deg crank angle"
        )
