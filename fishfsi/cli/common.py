"""Shared CLI plumbing: case argument, ``--set`` overrides, ``--json``, one-line errors."""

from __future__ import annotations

import argparse
import contextlib
import errno
import json
import math
import os
import signal
import sys
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any, NoReturn

import numpy as np

from fsi_orchestrator.case import Case, CaseError, load_case
from fsi_orchestrator.results import is_write_fault

EXIT_OK, EXIT_FAILED, EXIT_BAD_INPUT, EXIT_INTERRUPTED = 0, 1, 2, 130
EXIT_BROKEN_PIPE = 128 + signal.SIGPIPE  # the reader of stdout left (`| head`), as a shell's tools


def plural(count: int, noun: str) -> str:
    """'1 waveform', '2 waveforms', '2 frequencies'."""
    if count == 1:
        return f"1 {noun}"
    return f"{count} {noun[:-1] + 'ies' if noun.endswith('cy') else noun + 's'}"


class OneLineParser(argparse.ArgumentParser):
    """A bad command line is reported as all bad input is: one line, exit 2 (argparse's usage
    block is a --help away)."""

    def error(self, message: str) -> NoReturn:
        self.exit(EXIT_BAD_INPUT, f"error: {self.prog}: {message} (see {self.prog} --help)\n")


def base_parser(prog: str, description: str) -> argparse.ArgumentParser:
    parser = OneLineParser(
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
    add_version(parser)
    return parser


class _Version(argparse.Action):
    """``--version``: the package version and git commit, looked up only when asked."""

    def __init__(self, option_strings, dest=argparse.SUPPRESS, **kwargs) -> None:
        kwargs.setdefault("help", "print the version and exit")
        super().__init__(option_strings, dest, nargs=0, **kwargs)

    def __call__(self, parser, namespace, values, option_string=None) -> None:
        from fsi_orchestrator.provenance import version

        print(f"{parser.prog} {version()}")
        parser.exit()


def add_version(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--version", action=_Version)


def load(args: argparse.Namespace, static: bool | None = None) -> Case:
    """The validated case of a command: an empty case.toml is refused, and so is a plate that
    does not fit its clamp or its fluid domain (one line, exit 2, before any solver runs).
    ``static``: whether the command meets no liquid (default: the case's analysis is static;
    fsi-modal's wet modes meet it whatever the case's kind)."""
    from fsi_orchestrator.case.loader import blame_override

    case = load_case(args.case, args.overrides, allow_empty=False)
    try:
        check_plausible(case, static)
    except CaseError as err:  # a check across keys may follow from a --set
        given = list(args.overrides or ())
        raise CaseError(blame_override(str(err), given, derived=True)) from None
    return case


# clearance between the plate and the fluid domain's boundary, as a share of the body length
DOMAIN_MARGIN = 0.05


def check_plausible(case: Case, static: bool | None = None) -> None:
    """Checks across keys that need the resolved plate (a preset's body length): the clamp
    leaves part of the plate free, the tank or sphere holds the plate with a margin (unless
    ``static``, a solve that meets no liquid; default: the case's analysis is static)."""
    from fsi_orchestrator.case.schema import AnalysisKind, FluidDomain, FluidModel, key_spec
    from solid_adapter.geometry import build_layout  # the composition root may know adapters

    layout = build_layout(case)  # raises CaseError naming the key when the outline is wrong
    length = layout.length_m
    if layout.clamp_x_m is not None and layout.clamp_x_m >= length:
        raise CaseError(
            f"case.toml: boundary.clamp_length_m ({layout.clamp_x_m:g} m) must be shorter than "
            f"the plate ({length:g} m), or nothing is free to move"
        )
    f = case.fluid
    if static is None:
        static = case.analysis.kind is AnalysisKind.STATIC
    if static:  # a static solve meets no liquid
        return
    margin = DOMAIN_MARGIN * length
    height = float(np.max(layout.height(np.linspace(0.0, length, 201))))
    if f.model is FluidModel.POTENTIAL and f.domain is FluidDomain.SPHERE:
        reach = float(np.hypot(length / 2, height / 2))  # centre to the farthest corner
        if f.domain_diameter_m / 2 < reach + margin:
            needed = 2 * (reach + margin)
            largest = key_spec("fluid.domain_diameter_m").le
            beyond = (
                f' (beyond the sphere\'s {largest:g} m: use fluid.domain = "tank" with its '
                "size keys)"
                if largest is not None and needed > largest
                else ""
            )
            raise CaseError(
                f"case.toml: fluid.domain_diameter_m ({f.domain_diameter_m:g} m) must hold the "
                f"{length:g} m plate with a margin: at least {needed:.3g} m{beyond}"
            )
    elif f.model is FluidModel.OPENFOAM or (
        f.model is FluidModel.POTENTIAL and f.domain is FluidDomain.TANK
    ):
        nose = f.tank_nose_x_m if f.tank_nose_x_m is not None else (f.tank_length_m - length) / 2
        tail = f.tank_length_m - nose - length
        if min(nose, tail) < margin:
            key = "fluid.tank_nose_x_m" if f.tank_nose_x_m is not None else "fluid.tank_length_m"
            raise CaseError(
                f"case.toml: {key}: the tank ({f.tank_length_m:g} m long, nose at "
                f"{nose:g} m) must hold the {length:g} m plate with {margin:.3g} m to spare "
                f"ahead and behind"
            )
        if f.tank_depth_m < height + 2 * margin:
            raise CaseError(
                f"case.toml: fluid.tank_depth_m ({f.tank_depth_m:g} m) must hold the plate's "
                f"{height:g} m height with {margin:.3g} m to spare: at least "
                f"{height + 2 * margin:.3g} m"
            )
        if f.tank_width_m < 8 * margin:  # the tail of the seed's fish swings about 20 mm
            raise CaseError(
                f"case.toml: fluid.tank_width_m ({f.tank_width_m:g} m) leaves the plate less "
                f"than {4 * margin:.3g} m to swing on either side: at least {8 * margin:.3g} m"
            )


def plain(value: Any) -> Any:
    """numpy scalars and arrays as Python floats and lists."""
    if isinstance(value, dict):
        return {k: plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [plain(v) for v in value]
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return value


def to_jsonable(value: Any) -> Any:
    """Plain JSON values; a figure that is not finite (an uncertainty from one period, a failed
    point's amplitude) becomes null, since strict readers (jq, JavaScript) refuse NaN and
    Infinity."""
    if isinstance(value, dict):
        return {k: to_jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [to_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return to_jsonable(value.tolist())
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def json_text(value: Any, indent: int | None = None) -> str:
    """Strict JSON of ``value`` (see ``to_jsonable``)."""
    return json.dumps(to_jsonable(value), indent=indent, allow_nan=False)


# a figure --json prints as null (not known yet, or a failed point's), in the plain summary
NOT_KNOWN = "none"


def plain_text(value: Any) -> str:
    """One value of the plain summary: numbers to 6 digits, and what --json prints as null
    (None, NaN, infinity) as NOT_KNOWN, in lists and tables too."""
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return NOT_KNOWN
    if isinstance(value, float):
        return f"{value:.6g}"
    if isinstance(value, list):
        return "[" + ", ".join(plain_text(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k}: {plain_text(v)}" for k, v in value.items()) + "}"
    return str(value)


def emit(summary: dict[str, Any], as_json: bool) -> None:
    if as_json:
        print(json_text(summary))
        return
    table = plain(summary)
    width = max((len(key) for key in table), default=0)
    for key, value in table.items():
        print(f"{key:>{width}}: {plain_text(value)}")


@contextlib.contextmanager
def sigterm_as_interrupt() -> Iterator[None]:
    """SIGTERM (SLURM's time limit, scancel) as Ctrl-C: a running fluid is shut down and
    what is finished is kept (a sweep's rows, a study's evaluations). Only where nothing else
    handles SIGTERM already; the old handler comes back afterwards."""

    def interrupt(signum, frame):
        raise KeyboardInterrupt

    try:
        if signal.getsignal(signal.SIGTERM) is not signal.SIG_DFL:
            yield
            return
        previous = signal.signal(signal.SIGTERM, interrupt)
    except ValueError:  # not the main thread
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


RESUMABLE = "results so far are kept; continue with --resume"


def guarded(body: Callable[[], int], interrupted: str = RESUMABLE) -> int:
    """Run a CLI body; known failures become one line on stderr and an exit code. SIGTERM
    (SLURM's time limit, scancel) stops it as Ctrl-C does: one line, exit 130;
    ``interrupted`` says what is kept."""
    from fsi_orchestrator.loop import ResumeError
    from solid_adapter.solvers import SolverError  # the composition root may know adapters

    try:
        with sigterm_as_interrupt():
            return body()
    except CaseError as err:
        print(f"error: {err}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except (SolverError, ResumeError, RuntimeError) as err:
        print(f"error: {err}", file=sys.stderr)
        return EXIT_FAILED
    except BrokenPipeError:  # `--json | head`: the reader has what it wanted; no traceback
        # stdout's buffer cannot be flushed at exit either: point it at /dev/null
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_BROKEN_PIPE
    except OSError as err:
        # a full disk or a read-only folder met past the up-front checks; a denied read is
        # no write fault, so "permission denied" is all that is said of it
        if not is_write_fault(err) or not (err.filename or err.errno in FULL):
            raise
        from fsi_orchestrator.results import write_failure

        kept, _, then = interrupted.partition("; ")
        then = then or "run it again"
        if not err.filename:  # a stream (stdout to a full disk) has no name to give
            line = f"a write failed ({err.strerror}); {kept}; free space, then {then}"
        elif isinstance(err, WriteFault) or err.errno not in (errno.EACCES, errno.EPERM):
            line = str(write_failure(Path(err.filename), err, kept, then))
        else:
            line = f"{err.filename}: permission denied; {kept}; fix its permissions, then {then}"
        print(f"error: {line}", file=sys.stderr)
        return EXIT_FAILED
    except KeyboardInterrupt as err:  # Ctrl-C, or a SIGTERM the loop turned into a checkpoint
        from fsi_orchestrator.participant import ParticipantStopped

        why = str(err) or interrupted
        if isinstance(err, ParticipantStopped):  # a solver stopped outside the windows
            why = f"{err}; {interrupted}"
        print(f"interrupted: {why}", file=sys.stderr)
        return EXIT_INTERRUPTED


def run_main(
    body: Callable[[argparse.Namespace], int],
    parser: argparse.ArgumentParser,
    argv: Sequence[str] | None,
    interrupted: str = RESUMABLE,
) -> int:
    args = parser.parse_args(argv)
    return guarded(lambda: body(args), interrupted)


def cannot_write(output: Path, err: OSError, flag: str = "--output ") -> str:
    """One line for an output folder that cannot be made or written (``flag``: how the user
    named it; empty for a default folder)."""
    why = "it is a file" if output.is_file() else err.strerror
    return f"{flag}{output}: cannot write there ({why})"


def output_folder(given: str | None, default: Path) -> Path:
    """``--output``'s folder; an empty one (a shell variable that was not set) is refused
    rather than taken for the default. Absolute: OpenFOAM and its handshake scripts run in the
    case folder, where a relative path would point elsewhere."""
    if given is None:
        return default.absolute()
    if not given.strip():
        raise CaseError("--output is empty: give a folder, or leave --output out for the default")
    return Path(given).absolute()


FULL = (errno.ENOSPC, errno.EDQUOT)


class WriteFault(OSError):
    """A write of the command's own output that the disk refused (full, read-only, denied)."""


@contextlib.contextmanager
def replaced_atomically(path: Path, keep_suffix: bool = False) -> Iterator[Path]:
    """A temporary name beside ``path`` to write to; renamed to ``path`` when the block ends,
    removed when it fails (a full disk leaves no half file and no litter). ``keep_suffix``
    for a writer that picks its format from the name; otherwise the name ends in ``.tmp``,
    so that a folder's ``*.json`` or ``*.csv`` never lists it."""
    end = f".tmp{path.suffix}" if keep_suffix else ".tmp"
    tmp = path.with_name(f".{path.name}.{os.getpid()}{end}")
    try:
        yield tmp
        os.replace(tmp, path)
    except BaseException as err:
        with contextlib.suppress(OSError):
            tmp.unlink()
        if isinstance(err, OSError) and not isinstance(err, WriteFault) and is_write_fault(err):
            # named as the file meant, not the temporary one; callers can tell a write
            raise WriteFault(err.errno, err.strerror, str(path)) from err
        raise


def atomic_write(path: Path, text: str) -> None:
    """``text`` into ``path`` through a renamed temporary file: a reader, or a kill, never
    meets half a file."""
    with replaced_atomically(path) as tmp, open(tmp, "w", newline="") as fh:
        fh.write(text)
        fh.flush()
        os.fsync(fh.fileno())


def save_figure(fig: Any, path: Path) -> Path:
    """A matplotlib figure as ``path`` (its format from the suffix), whole or not at all;
    the figure is closed."""
    import matplotlib.pyplot as plt

    try:
        with replaced_atomically(path) as tmp:
            fig.savefig(tmp, dpi=120, format=path.suffix.lstrip("."))
    finally:
        plt.close(fig)
    return path
