"""Composition root: builds the solvers a case asks for. The only orchestrator module that
imports the adapters (lazily, so that `--help` and case errors stay fast)."""

from __future__ import annotations

import dataclasses

from ..case import Case
from ..case.schema import FluidDomain, FluidModel


def modal_fluid_case(case: Case) -> Case:
    """A modal study needs no CFD: an OpenFOAM case is analysed with the potential model in
    its tank."""
    if case.fluid.model is not FluidModel.OPENFOAM:
        return case
    fluid = dataclasses.replace(case.fluid, model=FluidModel.POTENTIAL, domain=FluidDomain.TANK)
    return dataclasses.replace(case, fluid=fluid)


def shell_with_fast_fluid(case: Case):
    """The shell model, with the fast fluid's added mass in its inertia when the case has one.
    Returns (model, added_mass or None)."""
    from fluid_adapter.fast import fast_added_mass
    from solid_adapter.build import build_shell_model

    model = build_shell_model(case)
    added = fast_added_mass(case, model)
    if added is not None:
        model.set_added_mass(added.matrix)
    return model, added
