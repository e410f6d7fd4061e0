"""Fast in-process fluids for scenes that need no CFD: the liquid enters the structure as an
interface added mass (potential flow in 3D, or strip theory), plus a modal damping estimate."""

from __future__ import annotations

from fsi_orchestrator.case import Case
from fsi_orchestrator.case.schema import FluidModel

from .potential import build_added_mass
from .potential.model import AddedMass
from .strip import strip_added_mass


def fast_added_mass(case: Case, shell_model) -> AddedMass | None:
    """The case's added-mass operator on the shell's nodal normal accelerations, or None."""
    if case.fluid.model is FluidModel.POTENTIAL:
        return build_added_mass(case, shell_model)
    if case.fluid.model is FluidModel.SLENDER_BODY:
        return strip_added_mass(
            shell_model, case.fluid.density_kg_m3, case.fluid.added_mass_coefficient
        )
    return None
