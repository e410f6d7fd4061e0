"""Partitioned FSI co-simulation of a piezo-driven soft robotic fish.

The coupling loop knows its solvers only through :class:`fsi_orchestrator.participant.Participant`;
it never imports scikit-fem, foamlib or OpenFOAM paths.
"""

__version__ = "0.1.0"
