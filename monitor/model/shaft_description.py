"""The shaft line as an engine description gives it: the crank throws' torsional and axial data, the
elements beyond them (damper, flywheel, shafts, propeller or generator).

The tables of the description's ``[shaft_line]``; :mod:`monitor.torsion.shaft_line` builds the
torsional model from them.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import AfterValidator, BaseModel, ConfigDict, Field

from monitor.model.quantities import Inertia, Mass, non_negative, positive

__all__ = ["CrankAxial", "ShaftElement", "ShaftLine"]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, strict=False)


class ShaftElement(_Strict):
    """One lumped element of the shaft line beyond the crank throws.

    Elements are listed from the engine outwards; each is joined to the one
    before it (the first to the nearest crank throw) by a shaft of the given
    stiffness and relative damping.
    """

    name: str
    kind: Literal["damper", "flywheel", "shaft", "gear", "propeller", "generator", "other"]
    inertia_kgm2: Annotated[float, AfterValidator(non_negative("kg m^2"))]
    stiffness_to_previous_nm_per_rad: Annotated[float, AfterValidator(positive("N m/rad"))]
    relative_damping_nms_per_rad: Annotated[float, AfterValidator(non_negative("N m s/rad"))] = Field(
        default=0.0, description="damping in the connection to the previous element (e.g. a damper's)"
    )
    absolute_damping_nms_per_rad: Annotated[float, AfterValidator(non_negative("N m s/rad"))] = Field(
        default=0.0, description="damping of this element to ground (e.g. propeller, generator)"
    )


class CrankAxial(_Strict):
    """Axial and coupling data of one crank throw (paper 001), for the torsional-axial model.

    Flexibilities of one crank with one journal fixed, at the other journal:
    axial (C11), lateral in the crank plane (C22) and across it (C33), radial
    displacement per axial force (C21) and tangential displacement per torque
    (C34); its torsional flexibility is ``1 / throw_stiffness``.
    """

    axial_flexibility_m_per_n: Annotated[float, AfterValidator(positive("m/N"))]
    radial_flexibility_m_per_n: Annotated[float, AfterValidator(positive("m/N"))]
    tangential_flexibility_m_per_n: Annotated[float, AfterValidator(positive("m/N"))]
    radial_per_axial_m_per_n: float = Field(description="C21 [m/N]")
    tangential_per_torque_m_per_nm: float = Field(description="C34 [m/(N m)]")
    throw_mass_kg: Mass = Field(description="mass of one throw moving axially with the crankshaft")
    thrust_bearing_stiffness_n_per_m: Annotated[float, AfterValidator(positive("N/m"))]
    stiffness_damping_s: Annotated[float, AfterValidator(non_negative("s"))] = Field(
        default=1e-4, description="damping proportional to stiffness, C = beta K"
    )


class ShaftLine(_Strict):
    """Torsional data of the crankshaft and the shafting (used by the torsion model)."""

    throw_inertia_kgm2: Inertia = Field(
        description="rotating inertia of one throw, without rod and reciprocating parts"
    )
    throw_stiffness_nm_per_rad: Annotated[float, AfterValidator(positive("N m/rad"))] = Field(
        description="torsional stiffness between adjacent throws"
    )
    free_end: list[ShaftElement] = Field(default_factory=list)
    driven_end: list[ShaftElement] = Field(default_factory=list)
    tooth_wheel: str | None = Field(
        default=None, description="name of the element that carries the crank-speed tooth wheel"
    )
    axial: CrankAxial | None = None
