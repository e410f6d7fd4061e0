"""Errors of the OpenFOAM adapter: each says which step failed, where, and how to fix it."""

from __future__ import annotations

from fsi_orchestrator.participant import ParticipantSetupError, ParticipantStopped

INSTALL_HINT = (
    "install the Debian package with `apt-get install -y openfoam` (v1912: binaries and "
    "libraries only), or put an OpenFOAM whose `etc/controlDict` lies in /usr/share/openfoam "
    "(or $WM_PROJECT_DIR) on PATH"
)


class OpenFoamError(RuntimeError):
    """Base class of everything the OpenFOAM adapter raises on purpose."""


class OpenFoamNotFoundError(OpenFoamError, ParticipantSetupError):
    """An OpenFOAM executable or its etc/ folder is missing."""


class OpenFoamRunError(OpenFoamError):
    """An OpenFOAM program stopped with an error; the case folder is kept for inspection."""


class OpenFoamStopped(ParticipantStopped):
    """An OpenFOAM program was stopped by a signal from outside (a scheduler's time limit)."""


class MeshQualityError(OpenFoamError):
    """checkMesh failed on the generated (or moved) mesh."""


class MeshFoldedError(MeshQualityError, ParticipantSetupError):
    """The moved mesh has cells inside out: no iterate of the window can go on from it."""


class DivergenceError(OpenFoamError):
    """The flow solution blew up: NaN, or residuals / Courant numbers beyond any sane bound."""


class LeadInDivergenceError(DivergenceError):
    """The flow blew up in the lead-in, the liquid alone following the fast model's orbit
    before window 1: a start from rest may run where that orbit does not."""


class DriverError(OpenFoamError, ParticipantSetupError):
    """A driver was asked for something it cannot do (e.g. going back in time while running)."""
