"""``fsi-modal CASE``: mode frequencies in vacuum (dry) and, with a fluid model, in the liquid."""

from __future__ import annotations

import argparse
from collections.abc import Sequence

from .common import EXIT_OK, base_parser, emit, load, run_main


def modal_summary(case) -> dict:
    from solid_adapter.build import build_shell_model, run_dry_modal

    model = build_shell_model(case)
    dry = run_dry_modal(case, model)
    return {"dry_hz": sorted(dry.frequencies_hz.tolist())}


def _body(args: argparse.Namespace) -> int:
    emit(modal_summary(load(args)), args.json)
    return EXIT_OK


def main(argv: Sequence[str] | None = None) -> int:
    parser = base_parser("fsi-modal", "Mode frequencies of the plate (dry; wet with a fluid).")
    return run_main(_body, parser, argv)


if __name__ == "__main__":
    raise SystemExit(main())
