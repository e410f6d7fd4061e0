"""Partitioned FSI co-simulation of a piezo-driven soft robotic fish.

The coupling loop knows its solvers only through :class:`fsi_orchestrator.participant.Participant`;
it never imports scikit-fem, foamlib or OpenFOAM paths.

The Python API (:mod:`fsi_orchestrator.api`): ``load_case(path, overrides=[...])``,
``run(case, output) -> Results``.
"""

__version__ = "0.1.0"

from .api import Case, CaseError, Results, load_case, run  # noqa: E402

__all__ = ["Case", "CaseError", "Results", "__version__", "load_case", "run"]
