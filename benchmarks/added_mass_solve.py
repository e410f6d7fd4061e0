"""The potential added mass M_a = rho D^T K^-1 D per fluid mesh level: the forward substitution
alone (K = L diag(u) L^T, M_a = Y^T diag(u)^-1 Y, ``fluid_adapter.potential.model``) against
both substitutions (X = K^-1 D, then D^T X) on the same factor, timed alternately in one run:
their ratio, and the two matrices' largest difference relative to the largest entry.

    .venv/bin/python benchmarks/added_mass_solve.py [--repeats 3]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
import skfem

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from skfem.models.poisson import laplace  # noqa: E402

from fluid_adapter.potential import build_fluid  # noqa: E402
from fluid_adapter.potential.model import coupling_matrix, schur_product  # noqa: E402
from fsi_orchestrator.case import load_case  # noqa: E402
from solid_adapter.build import build_shell_model  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def both_substitutions(K: sp.csc_matrix, D: sp.spmatrix) -> np.ndarray:
    lu = spla.splu(K, permc_spec="MMD_AT_PLUS_A", options={"SymmetricMode": True})
    return np.asarray(D.T @ lu.solve(D.toarray()))


def system(level: str) -> tuple[sp.csc_matrix, sp.spmatrix]:
    case = load_case(
        ROOT / "cases/fish_modal_free", ["fluid.model=potential", f"fluid.mesh_level={level}"]
    )
    shell = build_shell_model(case)
    fluid = build_fluid(case, shell)
    basis = skfem.Basis(fluid.mesh, skfem.ElementTetP2())
    free = np.setdiff1d(np.arange(basis.N), basis.get_dofs(fluid.dirichlet_facets).flatten())
    K = sp.csc_matrix(laplace.assemble(basis)[free][:, free])
    return K, coupling_matrix(basis, fluid, shell.mesh.basis.probes)[free]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    print(
        f"{'level':>8} {'unknowns':>9} {'shell dofs':>10} {'forward s':>10} {'both s':>8} "
        f"{'ratio':>6} {'max diff':>9}"
    )
    for level in ("coarse", "default"):
        K, D = system(level)
        times: dict[str, list[float]] = {"forward": [], "both": []}
        results = {}
        for _ in range(args.repeats):
            for name, solve in (("forward", schur_product), ("both", both_substitutions)):
                start = time.perf_counter()
                results[name] = solve(K, D)
                times[name].append(time.perf_counter() - start)
        forward, both = (float(np.median(times[n])) for n in ("forward", "both"))
        diff = np.abs(results["forward"] - results["both"]).max() / np.abs(results["both"]).max()
        print(
            f"{level:>8} {K.shape[0]:9d} {D.shape[1]:10d} {forward:10.2f} {both:8.2f} "
            f"{both / forward:6.1f} {diff:9.1e}"
        )


if __name__ == "__main__":
    main()
