"""The house's floors, read from every module's imports (also those inside functions). Imports
run one way, down: ``fsi_orchestrator`` (the ground floor) <- ``solid_adapter``,
``fluid_adapter`` <- ``fishfsi`` (the application layer) <- ``turek_hron`` (and benchmarks/).

- the core an adapter may use: ``fsi_orchestrator.case`` (the schema, the plate's planform) and
  ``fsi_orchestrator.participant`` (the contract);
- the orchestrator imports no adapter and no application layer: it knows solvers through the
  Participant protocol only, and its Python API (``load_case``, ``run``) finds the composition
  root through the entry point ``fsi_orchestrator.composition``, not by import;
- only the application layer (``fishfsi.cli``, ``fishfsi.design``) composes the adapters, and
  no adapter imports it;
- no adapter imports the other: what both need about the plate (its planform) is the core's
  ``fsi_orchestrator.case.planform``, and what needs both (the shell's first mode as the fluid's
  prescribed motion) is the application layer's (``fishfsi.cli.prescribed``);
- the benchmark geometries (``turek_hron``: the Turek & Hron channel, the plane-strain flag)
  stand beside the product: they may import it, no product module imports them.
"""

from __future__ import annotations

import ast
import tomllib
from importlib.metadata import entry_points
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
ADAPTERS = ("solid_adapter", "fluid_adapter")
CORE = ("fsi_orchestrator.case", "fsi_orchestrator.participant")
APP = ("fishfsi",)
PRODUCT = ("fsi_orchestrator", *ADAPTERS, *APP)
BENCHMARKS = ("turek_hron",)
# the floor of each top-level package: an import may run to a lower or the same floor only
FLOOR = {
    "fsi_orchestrator": 0,
    "solid_adapter": 1,
    "fluid_adapter": 1,
    "fishfsi": 2,
    "turek_hron": 3,
}


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


def edges(tops: tuple[str, ...] = PRODUCT) -> set[tuple[str, str]]:
    found = set()
    for top in tops:
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
    names = imports(ROOT / "fishfsi/cli/run.py")
    assert "fsi_orchestrator.loop" in names  # from ..loop import ...
    assert "solid_adapter.build" in names  # inside run_dynamic


def test_adapters_use_only_the_core_of_the_orchestrator():
    wrong = sorted(
        (s, t)
        for s, t in edges()
        if within(s, ADAPTERS) and t.startswith("fsi_orchestrator") and not within(t, CORE)
    )
    assert wrong == []


def test_the_orchestrator_imports_no_adapter():
    wrong = sorted(
        (s, t) for s, t in edges() if within(s, ("fsi_orchestrator",)) and within(t, ADAPTERS)
    )
    assert wrong == []


def test_neither_the_orchestrator_nor_an_adapter_imports_the_application_layer():
    wrong = sorted((s, t) for s, t in edges() if not within(s, APP) and within(t, APP))
    assert wrong == []


def test_imports_run_one_way_down_the_floors():
    assert set(FLOOR) == {*PRODUCT, *BENCHMARKS}
    up = sorted(
        (s, t)
        for s, t in edges((*PRODUCT, *BENCHMARKS))
        if FLOOR[t.split(".")[0]] > FLOOR[s.split(".")[0]]
    )
    assert up == []


def test_the_api_finds_the_composition_root_through_its_entry_point():
    declared = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["entry-points"]
    assert declared["fsi_orchestrator.composition"] == {"fishfsi": "fishfsi.cli.root"}
    (found,) = entry_points(group="fsi_orchestrator.composition")  # the installed package's
    assert found.value == "fishfsi.cli.root"
    root = found.load()
    assert callable(root.check_plausible) and callable(root.execute)


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
