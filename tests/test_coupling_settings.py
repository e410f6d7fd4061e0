"""Typed coupling settings: one frozen dataclass per scheme, validated when built, onto which
the case's flat [coupling] keys map (fsi_orchestrator/coupling_settings.py)."""

from __future__ import annotations

import dataclasses

import pytest

from fsi_orchestrator.case.schema import CouplingScheme
from fsi_orchestrator.coupling_settings import (
    CouplingSettings,
    CouplingSettingsError,
    Explicit,
    IQNILSAddedMass,
    IQNILSScheme,
    scheme_settings,
)


@pytest.mark.parametrize("scheme", list(CouplingScheme))
def test_every_scheme_has_settings_that_agree_with_its_capabilities(scheme):
    settings = CouplingSettings(scheme_settings=scheme_settings(scheme))
    assert settings.scheme is scheme
    assert settings.iterates(window=10) is scheme.iterates
    assert (settings.added_mass_scale is not None) is scheme.uses_added_mass
    assert settings.max_iterations == (50 if scheme.iterates else 1)
    accelerator = settings.scheme_settings.make_accelerator()
    assert (accelerator is None) is (scheme.accelerator is None)
    if accelerator is not None:
        assert accelerator.name == scheme.accelerator


def test_the_flat_keys_reach_only_the_schemes_that_read_them():
    am = scheme_settings(CouplingScheme.IQN_ILS_AM, added_mass_scale=0.7, explicit_windows=4)
    assert am == IQNILSAddedMass(initial_relaxation=1.0, added_mass_scale=0.7, explicit_windows=4)
    assert not am.iterates(3) and am.iterates(4)
    plain = scheme_settings(CouplingScheme.IQN_ILS, relaxation=0.2, added_mass_scale=0.7)
    assert plain == IQNILSScheme(initial_relaxation=0.2)
    assert scheme_settings(CouplingScheme.EXPLICIT, relaxation=0.2) == Explicit()
    with pytest.raises(dataclasses.FrozenInstanceError):
        plain.reuse_windows = 3  # type: ignore[misc]


@pytest.mark.parametrize(
    ("build", "field"),
    [
        (lambda: IQNILSScheme(initial_relaxation=1.7), "initial_relaxation"),
        (lambda: IQNILSScheme(max_iterations=0), "max_iterations"),
        (lambda: IQNILSAddedMass(added_mass_scale=0.0), "added_mass_scale"),
        (lambda: IQNILSAddedMass(explicit_windows=-1), "explicit_windows"),
        (lambda: CouplingSettings(scheme_settings=Explicit(), tolerance_rel=2.0), "tolerance_rel"),
    ],
)
def test_a_bad_value_is_refused_when_built_naming_the_field(build, field):
    with pytest.raises(ValueError, match=field):
        build()
    assert issubclass(CouplingSettingsError, ValueError)
