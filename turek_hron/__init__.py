"""The Turek & Hron (2006) benchmarks, beside the product: the channel with its cylinder and
flag (CFD1, CFD3, the FSI channel), the plane-strain flag, and the FSI1/FSI3 runner.

It imports the product packages (fsi_orchestrator, solid_adapter, fluid_adapter); no product
module imports it (tests/test_floors.py).

- :mod:`turek_hron.channel`: the channel mesh and case, CFD1 (steady);
- :mod:`turek_hron.cfd3`: CFD3 (periodic shedding) and its statistics;
- :mod:`turek_hron.fsi`: the channel as the FSI fluid participant;
- :mod:`turek_hron.plane_strain`: the plane-strain St. Venant-Kirchhoff flag;
- :mod:`turek_hron.run`: FSI1 (steady, pseudo-time) and FSI3 (dynamic) composed.
"""
