"""The application layer of fishfsi: the commands (``fishfsi.cli``: fsi-run, fsi-modal,
fsi-sweep, fsi-post, fsi-design) with the composition root that builds the adapters' solvers,
and the design studies (``fishfsi.design``).

It stands above the orchestrator (``fsi_orchestrator``: the case, the Participant contract, the
coupling) and the adapters (``solid_adapter``, ``fluid_adapter``); none of them imports it. The
Python API, ``fsi_orchestrator.load_case`` and ``fsi_orchestrator.run``, reaches it through the
entry point ``fsi_orchestrator.composition`` (``fishfsi.cli.root``).
"""
