"""The house's floors, read from every module's imports (also those inside functions):

- the core an adapter may use: ``fsi_orchestrator.case`` (the schema, the plate's planform) and
  ``fsi_orchestrator.participant`` (the contract);
- the orchestrator's own rooms (loop, coupling, acceleration, mapping, results, ...) import no
  adapter: they know solvers through the Participant protocol only;
- only the application layer (``fsi_orchestrator.cli``, ``fsi_orchestrator.design``, the API's
  ``run``) composes the adapters;
- no adapter imports the other: what both need about the plate (its planform) is the core's
  ``fsi_orchestrator.case.planform``, and what needs both (the shell's first mode as the fluid's
  prescribed motion) is the application layer's (``fsi_orchestrator.cli.prescribed``);
- the benchmark geometries (``turek_hron``: the Turek & Hron channel, the plane-strain flag)
  stand beside the product: they may import it, no product module imports them.
"""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
ADAPTERS = ("solid_adapter", "fluid_adapter")
CORE = ("fsi_orchestrator.case", "fsi_orchestrator.participant")
APP = ("fsi_orchestrator.cli", "fsi_orchestrator.design", "fsi_orchestrator.api")
PRODUCT = ("fsi_orchestrator", *ADAPTERS)
BENCHMARKS = ("turek_hron",)


def module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imports(path: Path) -> set[str]:
    """Absolute names of every module ``path`` imports (relative imports resolved)."""
    package = module_name(path).split(".")
    if path.name != "__init__.py":
        package = package[:-1]
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = package[: len(package) - node.level + 1] if node.level else []
            name = ".".join([*base, node.module] if node.module else base)
            found.add(name)
    return found


def edges() -> set[tuple[str, str]]:
    found = set()
    for top in PRODUCT:
        for path in (ROOT / top).rglob("*.py"):
            source = module_name(path)
            found.update(
                (source, target)
                for target in imports(path)
                if target.split(".")[0] in (*PRODUCT, *BENCHMARKS)
            )
    return found


def within(name: str, prefixes: tuple[str, ...]) -> bool:
    return any(name == p or name.startswith(p + ".") for p in prefixes)


def test_the_resolver_sees_relative_and_function_level_imports():
    names = imports(ROOT / "fsi_orchestrator/cli/run.py")
    assert "fsi_orchestrator.loop" in names  # from ..loop import ...
    assert "solid_adapter.build" in names  # inside run_dynamic


def test_adapters_use_only_the_core_of_the_orchestrator():
    wrong = sorted(
        (s, t)
        for s, t in edges()
        if within(s, ADAPTERS) and t.startswith("fsi_orchestrator") and not within(t, CORE)
    )
    assert wrong == []


def test_the_orchestrator_outside_its_application_layer_imports_no_adapter():
    wrong = sorted(
        (s, t)
        for s, t in edges()
        if s.startswith("fsi_orchestrator") and not within(s, APP) and within(t, ADAPTERS)
    )
    assert wrong == []


def test_no_adapter_imports_the_other():
    ties = sorted(
        (s, t)
        for s, t in edges()
        if within(s, ADAPTERS) and within(t, ADAPTERS) and s.split(".")[0] != t.split(".")[0]
    )
    assert ties == []


def test_no_product_module_imports_the_benchmarks():
    wrong = sorted((s, t) for s, t in edges() if within(t, BENCHMARKS))
    assert wrong == []


def test_the_benchmarks_stand_outside_the_product():
    assert all((ROOT / name / "__init__.py").is_file() for name in BENCHMARKS)
    assert not any(
        path.stem.startswith("turek") or path.stem == "plane_strain"
        for top in PRODUCT
        for path in (ROOT / top).rglob("*.py")
    )
