"""A V engine's banks: its cylinders' names, axes, throws and places, and its firing angles.

Conventions (docs/engines.md says them with a figure).

- Two banks, A and B, of ``m = n / 2`` cylinders each, named ``A1..Am`` and ``B1..Bm`` and numbered
  along the shaft from the end the description's ``cylinder_numbering`` names, as an in-line engine's.
  Cylinders ``Ak`` and ``Bk`` share crank throw ``k``: two rods on one crank pin. Inside the product
  a cylinder is an index in the order ``A1..Am, B1..Bm``.
- The bank angle ``g`` is the angle between the banks' axes. In the engine's frame (``y`` up the V's
  bisector, ``x`` across it, towards where the crank pin goes just after it passes ``y``) the leading
  bank (the one whose axis the crank pin passes first; ``leading_bank``) leans by ``-g/2``, the other
  by ``+g/2``: on each throw the trailing bank's cylinder reaches its top dead centre a crank angle
  ``g`` after the leading one's (on a four-stroke it may fire a revolution later, ``g + 360``).
- A cylinder's firing angle is as on an in-line engine: the crank angle of A1's crank from A1's firing
  TDC at which the cylinder reaches its own firing TDC. Its forces, across and along its own axis,
  are an in-line cylinder's at its own crank angle; :func:`to_engine_frame` turns them into the
  engine's frame, where the main bearings' vertical (``y``) and horizontal (``x``) are.
- Rods: ``side-by-side`` (each bank's rod on its own length of the crank pin, so the B bank stands
  ``bank_offset_m`` further along the shaft than the A bank), ``fork-and-blade`` (both rods in one
  plane: no offset) or ``articulated``: the leading bank's rod is the master, on the crank pin; the
  trailing bank's, the slave, hangs on the master's knuckle pin (``knuckle_radius_m`` from the crank
  pin's centre, ``knuckle_angle_deg`` from the master rod's axis towards the slave bank), so its piston
  moves otherwise (:mod:`monitor.model.articulated`: a stroke of its own, its TDC away from the bank
  angle). Both rods run in one plane. A trailing cylinder's firing angle stays the crank's (a bank
  angle after its master's); the firing order states when the cylinders reach their own TDCs, so a
  slave is ranked at its firing angle plus its TDC's offset (:func:`vee_firing_angles`).

Firing angles from the firing order, when ``firing.angles_deg`` does not give them: evenly spaced
(720 or 360 degrees over ``n``) if that puts each throw's two cylinders a bank angle apart; otherwise
each bank fires evenly on its own, as an in-line engine of ``m`` cylinders in the order its cylinders
appear, and each trailing cylinder a bank angle after its partner, in the revolution that makes the
engine fire in the stated order (the uneven intervals of, say, a 12-cylinder V of 55 degrees:
55, 65, 55, 65, ...). Given or found, the angles must put each throw's two cylinders a bank angle
apart; a description whose angles do not is refused, naming the throw.
"""

from __future__ import annotations

import itertools
import math
from typing import Annotated, Literal

import numpy as np
import numpy.typing as npt
from pydantic import AfterValidator, BaseModel, ConfigDict, Field, model_validator

from monitor.model.articulated import ArticulatedRod
from monitor.model.quantities import Length, Mass, between
from monitor.types import ComplexArray, FloatArray

__all__ = [
    "ANGLE_TOLERANCE_DEG",
    "Vee",
    "articulated_rod",
    "bank_axes",
    "cylinder_banks",
    "cylinder_names",
    "cylinder_throws",
    "slave_cylinders",
    "slave_masses",
    "tdc_offsets",
    "to_engine_frame",
    "vee_crank_angles",
    "vee_firing_angles",
]

#: How far a throw's two cylinders' firing angles may stand from a bank angle apart (rounding of the
#: angles a maker prints, to a tenth of a degree) [deg].
ANGLE_TOLERANCE_DEG = 0.05

Rods = Literal["side-by-side", "fork-and-blade", "articulated"]


class Vee(BaseModel):
    """The ``[vee]`` table of an engine description: two banks on one crankshaft."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    bank_angle_deg: Annotated[float, AfterValidator(between(1.0, 180.0, "deg"))] = Field(
        description="angle between the two banks' cylinder axes"
    )
    leading_bank: Literal["A", "B"] = Field(
        default="A", description="the bank whose axis the crank pin passes first as the crank turns"
    )
    rods: Rods = Field(description="'side-by-side', 'fork-and-blade' or 'articulated' connecting rods")
    bank_offset_m: Annotated[float, AfterValidator(between(-1.0, 1.0, "m", "was it given in mm?"))] = Field(
        default=0.0,
        description=(
            "side-by-side rods: how much further along the shaft (towards higher cylinder numbers) the "
            "B bank's cylinders stand than the A bank's"
        ),
    )
    knuckle_radius_m: (
        Annotated[float, AfterValidator(between(0.0, 2.0, "m", "was it given in mm?"))] | None
    ) = Field(default=None, description="articulated rods: crank pin centre to knuckle pin centre")
    knuckle_angle_deg: Annotated[float, AfterValidator(between(-180.0, 180.0, "deg"))] | None = Field(
        default=None,
        description="articulated rods: the knuckle pin's angle from the master rod's axis, to the slaves",
    )
    slave_rod_length_m: Length | None = Field(
        default=None, description="articulated rods: knuckle pin centre to slave piston pin centre"
    )
    slave_rod_kg: Mass | None = Field(default=None, description="articulated rods: the slave rod's mass")
    slave_rod_cg_from_piston_pin_m: Length | None = Field(
        default=None, description="articulated rods: the slave rod's centre of gravity from its piston pin"
    )

    @model_validator(mode="after")
    def _arrangement(self) -> Vee:
        """Refuse an offset where rods share a plane, and articulated rods without their geometry (or
        its fields with other rods)."""
        if self.rods != "side-by-side" and self.bank_offset_m != 0.0:
            raise ValueError(
                f"bank_offset_m = {self.bank_offset_m!r} with {self.rods} rods: both rods run in one "
                "plane, so the banks stand at the same place along the shaft (expected 0)"
            )
        given = {name: getattr(self, name) for name in _SLAVE_FIELDS}
        if self.rods == "articulated":
            missing = [name for name, value in given.items() if value is None]
            if missing:
                raise ValueError(
                    f"rods = 'articulated' needs {', '.join(missing)} (the slave rod and its pin)"
                )
            if not self.slave_rod_cg_from_piston_pin_m < self.slave_rod_length_m:  # type: ignore[operator]
                raise ValueError(
                    f"slave_rod_cg_from_piston_pin_m = {self.slave_rod_cg_from_piston_pin_m!r}: expected "
                    f"less than the slave rod's length {self.slave_rod_length_m!r} m"
                )
        elif any(value is not None for value in given.values()):
            stray = [name for name, value in given.items() if value is not None]
            raise ValueError(f"{', '.join(stray)}: for rods = 'articulated' only (rods = {self.rods!r})")
        return self


_SLAVE_FIELDS = (
    "knuckle_radius_m",
    "knuckle_angle_deg",
    "slave_rod_length_m",
    "slave_rod_kg",
    "slave_rod_cg_from_piston_pin_m",
)


def slave_cylinders(cylinders: int, vee: Vee | None) -> npt.NDArray[np.bool_]:
    """Which cylinders, by index, hang on an articulated rod's knuckle pin: the trailing bank's.

    Parameters
    ----------
    cylinders : int
    vee : Vee or None

    Returns
    -------
    ndarray of bool, shape (cylinders,)
        None of them in line or with side-by-side or fork-and-blade rods.
    """
    if vee is None or vee.rods != "articulated":
        return np.zeros(cylinders, dtype=bool)
    return np.asarray(_leads(vee, cylinders) == 0.0)


def tdc_offsets(cylinders: int, vee: Vee | None, rod: ArticulatedRod | None) -> FloatArray:
    """How far each cylinder's own TDC lies after the crank angle its firing angle names, by index:
    an articulated rod's slave's ``tdc_offset`` (:class:`~monitor.model.articulated.SlaveStroke`), 0
    for every other cylinder [rad].

    Parameters
    ----------
    cylinders : int
    vee : Vee or None
    rod : ArticulatedRod or None
        The engine's (``Engine.articulated``).

    Returns
    -------
    ndarray, shape (cylinders,)
    """
    offsets = np.zeros(cylinders)
    if rod is not None:
        offsets[slave_cylinders(cylinders, vee)] = rod.stroke().tdc_offset
    return offsets


def slave_masses(vee: Vee, piston_kg: float) -> tuple[float, float]:
    """An articulated slave's moving masses, its rod split as the two-mass rod
    (:mod:`monitor.model.articulated`).

    Parameters
    ----------
    vee : Vee
        With articulated rods.
    piston_kg : float
        The piston assembly's mass [kg].

    Returns
    -------
    reciprocating, knuckle : float
        The piston and the rod's piston-pin share; the rod's knuckle-pin share [kg].
    """
    if (
        vee.slave_rod_kg is None
        or vee.slave_rod_cg_from_piston_pin_m is None
        or vee.slave_rod_length_m is None
    ):
        raise ValueError(f"rods = {vee.rods!r}: no slave rod")
    share = vee.slave_rod_cg_from_piston_pin_m / vee.slave_rod_length_m
    return piston_kg + vee.slave_rod_kg * (1 - share), vee.slave_rod_kg * share


def articulated_rod(vee: Vee | None, crank_radius: float, rod_length: float) -> ArticulatedRod | None:
    """The master and slave rods of a V engine with articulated rods (module docstring), else None.

    Parameters
    ----------
    vee : Vee or None
    crank_radius : float
        [m].
    rod_length : float
        The master rod's, crank pin to piston pin [m].

    Returns
    -------
    ArticulatedRod or None

    Raises
    ------
    ModelError
        For a linkage that cannot work (:class:`~monitor.model.articulated.ArticulatedRod`).
    """
    if vee is None or vee.rods != "articulated":
        return None
    assert vee.knuckle_radius_m is not None and vee.knuckle_angle_deg is not None
    assert vee.slave_rod_length_m is not None
    return ArticulatedRod(
        crank_radius=crank_radius,
        master_length=rod_length,
        knuckle_radius=vee.knuckle_radius_m,
        knuckle_angle=math.radians(vee.knuckle_angle_deg),
        slave_length=vee.slave_rod_length_m,
        bank_angle=math.radians(vee.bank_angle_deg),
    )


def cylinder_names(cylinders: int, vee: Vee | None) -> list[str]:
    """Each cylinder's name, by index: ``1..n`` in line, ``A1..Am, B1..Bm`` on a V.

    Parameters
    ----------
    cylinders : int
    vee : Vee or None

    Returns
    -------
    list of str
    """
    if vee is None:
        return [str(c) for c in range(1, cylinders + 1)]
    half = cylinders // 2
    return [f"A{k}" for k in range(1, half + 1)] + [f"B{k}" for k in range(1, half + 1)]


def cylinder_banks(cylinders: int, vee: Vee | None) -> list[str]:
    """Each cylinder's bank, by index: ``""`` in line (one bank), ``"A"`` or ``"B"`` on a V (its name's
    letter, :func:`cylinder_names`).

    Parameters
    ----------
    cylinders : int
    vee : Vee or None

    Returns
    -------
    list of str
    """
    return [name[0] if vee is not None else "" for name in cylinder_names(cylinders, vee)]


def cylinder_throws(cylinders: int, vee: Vee | None) -> list[int]:
    """Each cylinder's crank throw (0-based), by index.

    Parameters
    ----------
    cylinders : int
    vee : Vee or None

    Returns
    -------
    list of int
    """
    if vee is None:
        return list(range(cylinders))
    half = cylinders // 2
    return [c % half for c in range(cylinders)]


def _leads(vee: Vee, cylinders: int) -> FloatArray:
    """1 for each cylinder of the leading bank, 0 for the trailing one's."""
    half = cylinders // 2
    a = np.r_[np.ones(half), np.zeros(half)]
    return a if vee.leading_bank == "A" else 1.0 - a


def bank_axes(cylinders: int, vee: Vee | None) -> FloatArray:
    """Each cylinder's axis from the engine's vertical, towards ``+x`` [rad] (0 in line).

    Parameters
    ----------
    cylinders : int
    vee : Vee or None

    Returns
    -------
    ndarray, shape (cylinders,)
    """
    if vee is None:
        return np.zeros(cylinders)
    half_angle = math.radians(vee.bank_angle_deg) / 2
    return np.where(_leads(vee, cylinders) == 1.0, -half_angle, half_angle)


def _pair_problem(angles_deg: FloatArray, vee: Vee) -> str | None:
    """Which throw's two cylinders are not a bank angle apart (mod 360), in words, or None."""
    half = angles_deg.size // 2
    names = cylinder_names(angles_deg.size, vee)
    lead = _leads(vee, angles_deg.size)
    for k in range(half):
        first, second = (k, k + half) if lead[k] == 1.0 else (k + half, k)
        gap = (angles_deg[second] - angles_deg[first]) % 360.0
        miss = abs((gap - vee.bank_angle_deg + 180.0) % 360.0 - 180.0)
        if miss > ANGLE_TOLERANCE_DEG:
            return (
                f"throw {k + 1} carries {names[first]} and {names[second]}, whose firing angles "
                f"{angles_deg[first]:g} and {angles_deg[second]:g} deg are {gap:g} deg apart "
                f"(mod 360): expected the bank angle {vee.bank_angle_deg:g} deg, {names[second]} trailing"
            )
    return None


def _fires_in_order(angles_deg: FloatArray, order: list[int], span: float) -> bool:
    """Whether the angles (mod ``span``) put the cylinders in ``order``, cyclically, none together."""
    wrapped = np.mod(angles_deg - angles_deg[order[0]], span)
    ranked = np.argsort(wrapped, kind="stable").tolist()
    return bool(np.all(np.diff(np.sort(wrapped)) > ANGLE_TOLERANCE_DEG)) and ranked == order


def _per_bank(order: list[int], vee: Vee, span: float, own: FloatArray) -> list[FloatArray]:
    """Each bank even on its own, the trailing cylinders in a revolution that keeps the order at their
    own TDCs (``own`` past their crank's [deg]): every way that does (more than one when the order does
    not say which revolution, as a V-twin's)."""
    n = len(order)
    half = n // 2
    lead = _leads(vee, n)
    leading = [c for c in order if lead[c] == 1.0]
    angles = np.zeros(n)
    for position, c in enumerate(leading):
        angles[c] = position * span / half
    trailing = [c for c in range(n) if lead[c] == 0.0]
    partner = {c: (c + half) % n for c in trailing}
    revolutions = round(span / 360.0)
    found = []
    for turns in itertools.product(range(revolutions), repeat=len(trailing)):
        for c, turn in zip(trailing, turns, strict=True):
            angles[c] = (angles[partner[c]] + vee.bank_angle_deg + 360.0 * turn) % span
        if _fires_in_order(angles + own, order, span):
            found.append(angles.copy())
    return found


def vee_firing_angles(
    order: list[int],
    vee: Vee,
    *,
    cycle_revolutions: int,
    given_deg: npt.ArrayLike | None = None,
    own_tdc_deg: npt.ArrayLike | None = None,
) -> FloatArray:
    """A V engine's firing angles, from A1 [deg] (module docstring).

    Parameters
    ----------
    order : list of int
        The firing order, as cylinder indices (0-based, ``A1..Am, B1..Bm``).
    vee : Vee
    cycle_revolutions : int
        1 two-stroke, 2 four-stroke.
    given_deg : array_like, optional
        The description's firing angles, by index; checked, not derived [deg].
    own_tdc_deg : array_like, optional
        How far each cylinder's own TDC lies past its crank's (an articulated slave's
        ``tdc_offset``, :func:`tdc_offsets`) [deg]: the order states when the cylinders fire, at their
        own TDCs. Default none.

    Returns
    -------
    ndarray, shape (n,)
        Each cylinder's firing angle after A1's, in ``[0, 360 * cycle_revolutions)`` [deg].

    Raises
    ------
    ValueError
        When no angles put each throw's two cylinders a bank angle apart in the stated order, or the
        given angles do not.
    """
    n = len(order)
    span = 360.0 * cycle_revolutions
    own = np.zeros(n) if own_tdc_deg is None else np.asarray(own_tdc_deg, dtype=np.float64)
    if given_deg is not None:
        angles = np.asarray(given_deg, dtype=np.float64)
        problem = _pair_problem(angles, vee)
        if problem is not None:
            raise ValueError(f"firing.angles_deg: {problem}")
        return angles
    even = np.empty(n)
    for position, c in enumerate(order):
        even[c] = position * span / n - own[c]  # even at their own TDCs
    if _pair_problem(even, vee) is None:
        return np.mod(even - even[0], span)
    found = _per_bank(order, vee, span, own)
    if len(found) != 1:
        names = cylinder_names(n, vee)
        why = (
            "neither even firing nor each bank firing evenly puts every throw's two cylinders a bank "
            "angle apart in this order; check the order, or give"
            if not found
            else f"{len(found)} ways of firing each bank evenly keep this order (it does not say in which "
            "revolution a trailing cylinder fires); give"
        )
        raise ValueError(
            f"firing.order = {[names[c] for c in order]} with a bank angle of {vee.bank_angle_deg:g} deg: "
            f"{why} firing.angles_deg (by cylinder, {names[0]}..{names[-1]})"
        )
    return np.mod(found[0] - found[0][0], span)


def vee_crank_angles(
    order: list[int],
    vee: Vee,
    rod: ArticulatedRod | None,
    cycle_revolutions: int,
    given_deg: npt.ArrayLike | None,
) -> FloatArray:
    """A V engine's firing angles from A1's own TDC [rad]: :func:`vee_firing_angles` from the order of
    the cylinders' own TDCs, shifted by A1's own offset (an articulated slave A1's TDC lies its
    ``tdc_offset`` past where its crank points along its bore; :func:`tdc_offsets`).

    Parameters
    ----------
    order : list of int
        The firing order, as cylinder indices (0-based).
    vee : Vee
    rod : ArticulatedRod or None
        The engine's articulated rods.
    cycle_revolutions : int
    given_deg : array_like or None
        The description's firing angles [deg].

    Returns
    -------
    ndarray, shape (n,)
        In ``[0, 2 pi cycle_revolutions)`` [rad].
    """
    own = tdc_offsets(len(order), vee, rod)
    found = vee_firing_angles(
        order, vee, cycle_revolutions=cycle_revolutions, given_deg=given_deg, own_tdc_deg=np.degrees(own)
    )
    return np.asarray(np.mod(np.radians(found) - own[0], 2 * np.pi * cycle_revolutions))


def to_engine_frame(forces: npt.ArrayLike, axes: npt.ArrayLike) -> ComplexArray:
    """Turn each cylinder's forces from its own axes into the engine's (module docstring).

    A cylinder whose axis leans by ``p`` towards ``+x`` has its own ``x`` along ``(cos p, -sin p)`` and
    its own ``y`` along ``(sin p, cos p)``. The map is linear, so it acts on order coefficients as on
    forces in time.

    Parameters
    ----------
    forces : array_like, shape (n_cylinders, 2, ...)
        Across (``x``) and along (``y``) each cylinder's axis [N] (or any force's order coefficients).
    axes : array_like, shape (n_cylinders,)
        Each cylinder's lean [rad] (:func:`bank_axes`).

    Returns
    -------
    ndarray, complex, the shape of ``forces``
        Horizontal (``x``) and vertical (``y``) in the engine's frame.
    """
    f = np.asarray(forces, dtype=np.complex128)
    p = np.asarray(axes, dtype=np.float64).reshape((-1,) + (1,) * (f.ndim - 2))
    cos_p, sin_p = np.cos(p), np.sin(p)
    across, along = f[:, 0], f[:, 1]
    return np.stack([across * cos_p + along * sin_p, -across * sin_p + along * cos_p], axis=1)
