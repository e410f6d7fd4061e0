"""OpenFOAM (v1912, Debian package) fluid adapter: the fish in the seed's tank, moving mesh,
loads out, relaunch and persistent drivers behind the Participant protocol.

Entry point: :func:`build_openfoam_participant`. Design and measured figures: docs/openfoam.md.
"""

from .build import build_openfoam_participant, case_schedule
from .errors import (
    DivergenceError,
    DriverError,
    LeadInDivergenceError,
    MeshFoldedError,
    MeshQualityError,
    OpenFoamError,
    OpenFoamNotFoundError,
    OpenFoamRunError,
)
from .participant import OpenFoamParticipant

__all__ = [
    "DivergenceError",
    "DriverError",
    "LeadInDivergenceError",
    "MeshFoldedError",
    "MeshQualityError",
    "OpenFoamError",
    "OpenFoamNotFoundError",
    "OpenFoamParticipant",
    "OpenFoamRunError",
    "build_openfoam_participant",
    "case_schedule",
]
