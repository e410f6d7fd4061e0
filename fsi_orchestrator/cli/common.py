"""Shared CLI plumbing: case argument, ``--set`` overrides, ``--json``, one-line errors."""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from ..case import Case, CaseError, load_case

EXIT_OK, EXIT_FAILED, EXIT_BAD_INPUT, EXIT_INTERRUPTED = 0, 1, 2, 130


def base_parser(prog: str, description: str) -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog=prog,
        description=description,
        epilog="Every case key, its unit and default: docs/case_format.md.",
    )
    parser.add_argument("case", help="case folder (holding case.toml)")
    parser.add_argument(
        "--set",
        dest="overrides",
        action="append",
        default=[],
        metavar="SECTION.KEY=VALUE",
        help="override a case value, e.g. --set actuation.frequency_hz=5",
    )
    parser.add_argument("--json", action="store_true", help="print the result summary as JSON")
    return parser


def load(args: argparse.Namespace) -> Case:
    return load_case(args.case, args.overrides)


def to_jsonable(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: to_jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [to_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return value


def emit(summary: dict[str, Any], as_json: bool) -> None:
    summary = to_jsonable(summary)
    if as_json:
        print(json.dumps(summary))
        return
    for key, value in summary.items():
        if isinstance(value, list) and value and isinstance(value[0], float):
            value = "[" + ", ".join(f"{v:.6g}" for v in value) + "]"
        elif isinstance(value, float):
            value = f"{value:.6g}"
        print(f"{key:>32}: {value}")


def guarded(body: Callable[[], int]) -> int:
    """Run a CLI body; known failures become one line on stderr and an exit code."""
    from solid_adapter.solvers import SolverError  # the composition root may know adapters

    from ..loop import ResumeError

    try:
        return body()
    except CaseError as err:
        print(f"error: {err}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except (SolverError, ResumeError, RuntimeError) as err:
        print(f"error: {err}", file=sys.stderr)
        return EXIT_FAILED
    except KeyboardInterrupt:
        print("interrupted: results so far are kept; continue with --resume", file=sys.stderr)
        return EXIT_INTERRUPTED


def run_main(
    body: Callable[[argparse.Namespace], int],
    parser: argparse.ArgumentParser,
    argv: Sequence[str] | None,
) -> int:
    args = parser.parse_args(argv)
    return guarded(lambda: body(args))
