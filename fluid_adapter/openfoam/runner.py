"""Running OpenFOAM programs: environment, logs, privilege drop, MPI, and errors that carry the
end of the log.

Every binary of the Debian v1912 package needs ``WM_PROJECT_DIR`` (its ``etc/controlDict``),
else even blockMesh stops. The ``systemCall`` function object the persistent driver relies on
is silently disabled for root, so a process that needs it runs as the unprivileged ``nobody``
(``setpriv``); ``mpirun`` as root needs the ``OMPI_ALLOW_RUN_AS_ROOT`` pair. Each run writes
``log.<name>`` in the case folder, the folder is kept when a run fails, and the error quotes
the last lines of the log.
"""

from __future__ import annotations

import errno
import math
import os
import re
import shutil
import signal
import stat
import subprocess
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from .errors import (
    INSTALL_HINT,
    DivergenceError,
    OpenFoamNotFoundError,
    OpenFoamRunError,
    OpenFoamStopped,
)

DEFAULT_PROJECT_DIR = Path("/usr/share/openfoam")
NOBODY_UID = 65534  # Debian's nobody:nogroup
TAIL_LINES = 25
SCANNED_LINES = 120  # a running solver's window (one step: ~40 lines) checked for divergence
# Residuals are normalised: anything far above 1 (or a NaN) means the solution has blown up.
RESIDUAL_LIMIT = 1e3
COURANT_LIMIT = 1e3
GATE_VARIABLE = "FISHFSI_GATE"


def project_dir() -> Path:
    """The OpenFOAM installation's root (holds etc/controlDict)."""
    given = os.environ.get("WM_PROJECT_DIR")
    for candidate in ([Path(given)] if given else []) + [DEFAULT_PROJECT_DIR]:
        if (candidate / "etc" / "controlDict").is_file():
            return candidate
    raise OpenFoamNotFoundError(
        f"OpenFOAM's etc/controlDict not found under $WM_PROJECT_DIR={given!r} nor "
        f"{DEFAULT_PROJECT_DIR}: {INSTALL_HINT}"
    )


def executable(name: str) -> str:
    path = shutil.which(name)
    if path is None:
        raise OpenFoamNotFoundError(f"OpenFOAM program `{name}` is not on PATH: {INSTALL_HINT}")
    return path


def is_root() -> bool:
    return os.geteuid() == 0


def foam_env(case: Path, parallel: bool = False) -> dict[str, str]:
    env = dict(os.environ)
    env["PWD"] = str(case)
    env["WM_PROJECT_DIR"] = str(project_dir())
    env.setdefault("FOAM_SIGFPE", "true")  # a NaN stops the run at once instead of spreading
    if parallel and is_root():
        env["OMPI_ALLOW_RUN_AS_ROOT"] = "1"
        env["OMPI_ALLOW_RUN_AS_ROOT_CONFIRM"] = "1"
    return env


def unreachable_for_nobody(path: Path) -> Path | None:
    """As root: the first parent of ``path`` that ``nobody`` cannot pass (None: all can)."""
    if not is_root():
        return None
    for parent in path.resolve().parents:
        if not parent.stat().st_mode & stat.S_IXOTH:
            return parent
    return None


def give_to_nobody(path: Path) -> None:
    """Let an unprivileged OpenFOAM write in a case folder created by root."""
    if not is_root():
        return
    parent = unreachable_for_nobody(path)
    if parent is not None:
        raise OpenFoamRunError(
            f"the persistent driver runs OpenFOAM as 'nobody' (systemCall is disabled for "
            f"root), but {parent} is not searchable by others "
            f"(mode {stat.filemode(parent.stat().st_mode)}): put the work folder under a "
            f"world-searchable directory such as /tmp, or run as a non-root user"
        )
    for root, dirs, files in os.walk(path):
        # a running solver may add (and the driver remove) entries meanwhile
        for entry in [root] + [os.path.join(root, name) for name in dirs + files]:
            try:
                os.chown(entry, NOBODY_UID, NOBODY_UID, follow_symlinks=False)
            except FileNotFoundError:
                continue


@dataclass(frozen=True, kw_only=True)
class Command:
    """One OpenFOAM program call: ``app args`` in ``case``, optionally on MPI ranks."""

    app: str
    case: Path
    args: tuple[str, ...] = ()
    processes: int = 1
    unprivileged: bool = False  # drop root (needed for systemCall)
    log_name: str | None = None
    gate: Path | None = None  # a FIFO the start-up waits at (write_start_up_gate)
    handshake: tuple[Path, Path] | None = None  # the ready and go pipes (persistent driver)

    @property
    def log(self) -> Path:
        return self.case / f"log.{self.log_name or self.app}"

    @property
    def cwd(self) -> Path:
        """Decomposed timeVaryingMappedFixedValue opens ``../constant/boundaryData`` relative
        to the working directory: start parallel runs from a processor folder."""
        case = self.case.absolute()  # OpenFOAM takes a relative -case from the cwd
        return case / "processor0" if self.processes > 1 else case

    def argv(self) -> list[str]:
        cmd = [executable(self.app), "-case", str(self.case.absolute()), *self.args]
        if self.processes > 1:
            cmd = [executable("mpirun"), "-np", str(self.processes), *cmd, "-parallel"]
        options = []
        if self.processes == 1:
            # dies with Python: a process waiting at a gate or handshake would otherwise wait
            # forever after a killed run (set after the change of user, which clears it)
            options += ["--pdeathsig", "SIGKILL"]
        if self.unprivileged and is_root():
            options += [f"--reuid={NOBODY_UID}", f"--regid={NOBODY_UID}", "--clear-groups"]
        return [executable("setpriv"), *options, *cmd] if options else cmd

    def env(self) -> dict[str, str]:
        env = foam_env(self.cwd, parallel=self.processes > 1)
        if self.gate is not None:  # absolute: OpenFOAM reads them from its case folder
            env[GATE_VARIABLE] = str(self.gate.absolute())
        if self.handshake is not None:  # per process: all share one controlDict
            ready, go = (path.absolute() for path in self.handshake)
            env["FISHFSI_READY"], env["FISHFSI_GO"] = str(ready), str(go)
        return env


def write_start_up_gate(case: Path) -> None:
    """A hook late in a solver's start-up: ``constant/fvOptions`` (read after the mesh, the
    fields and the turbulence model are loaded; this case has no options) includes the file
    named by $FISHFSI_GATE if present. A launch whose gate is a FIFO blocks there, loaded,
    until :func:`open_gate` writes to it; any other launch reads nothing."""
    header = "FoamFile { version 2.0; format ascii; class dictionary; object fvOptions; }"
    (case / "constant" / "fvOptions").write_text(
        f'{header}\n#includeIfPresent "${GATE_VARIABLE}"\n'
    )


def open_gate(command: Command, proc: subprocess.Popen) -> None:
    """Let a launch waiting at its start-up gate go on (waits until it reaches the gate)."""
    assert command.gate is not None
    while True:
        try:  # a FIFO opens for writing only once its reader is there
            fd = os.open(command.gate, os.O_WRONLY | os.O_NONBLOCK)
            break
        except OSError as err:
            if err.errno != errno.ENXIO:
                raise
        if proc.poll() is not None:
            check_finished(command, proc.returncode or 1)
            raise OpenFoamRunError(
                f"{command.app} in {command.case} ended before its start-up gate; see {command.log}"
            )
        time.sleep(0.002)
    try:
        os.write(fd, b"// go\n")
    finally:
        os.close(fd)  # the reader sees end-of-file: the include is complete


def wait_finished(command: Command, proc: subprocess.Popen) -> Path:
    """Wait for a launch to end; raise as :func:`run` does."""
    check_finished(command, proc.wait())
    return command.log


def run(command: Command, timeout_s: float | None = None) -> Path:
    """Run to completion; raise with the log's tail if it fails or diverges. Returns the log."""
    with open(command.log, "w") as log:
        try:
            proc = subprocess.run(
                command.argv(),
                cwd=command.cwd,
                env=command.env(),
                stdout=log,
                stderr=subprocess.STDOUT,
                timeout=timeout_s,
                check=False,
            )
        except subprocess.TimeoutExpired as exc:
            raise OpenFoamRunError(
                f"{command.app} in {command.case} ran past {timeout_s} s; "
                f"last lines of {command.log}:\n{tail(command.log)}"
            ) from exc
    check_finished(command, proc.returncode)
    return command.log


def launch(command: Command) -> subprocess.Popen:
    """Start in the background (own process group, so it can be stopped with its children)."""
    log = open(command.log, "w")  # closed by the driver with the process
    return subprocess.Popen(
        command.argv(),
        cwd=command.cwd,
        env=command.env(),
        stdout=log,
        stderr=subprocess.STDOUT,
        start_new_session=True,
    )


# how a program stopped by SIGHUP, SIGINT or SIGTERM ends: killed by the signal (negative,
# from Popen), or as mpirun reports a rank it saw killed (128 + the signal)
STOP_SIGNALS = (signal.SIGHUP, signal.SIGINT, signal.SIGTERM)
STOPPED_CODES = {-s for s in STOP_SIGNALS} | {128 + s for s in STOP_SIGNALS}


def check_finished(command: Command, returncode: int) -> None:
    if returncode in STOPPED_CODES:
        number = abs(returncode) % 128
        raise OpenFoamStopped(
            f"{command.app} was stopped by {signal.Signals(number).name} (a scheduler's time "
            f"limit, scancel or Ctrl-C) in {command.case}"
        )
    whole = command.log.read_text(errors="replace") if command.log.is_file() else ""
    reason = divergence(whole)
    if reason is not None:
        raise DivergenceError(
            f"{command.app} diverged in {command.case}: {reason}; reduce the time step "
            f"(time.steps_per_period) or refine the mesh. Case folder kept. "
            f"Last lines of {command.log}:\n{tail(command.log)}"
        )
    if returncode != 0:
        raise OpenFoamRunError(
            f"{command.app} failed (exit {returncode}) in {command.case}; case folder kept. "
            f"Last lines of {command.log}:\n{tail(command.log)}"
        )


def check_log(command: Command) -> None:
    """Divergence check of a running solver's latest log lines."""
    reason = divergence(tail(command.log, SCANNED_LINES))
    if reason is not None:
        raise DivergenceError(
            f"{command.app} diverged in {command.case}: {reason}; reduce the time step "
            f"(time.steps_per_period) or refine the mesh. Case folder kept. "
            f"Last lines of {command.log}:\n{tail(command.log)}"
        )


def tail(path: Path, lines: int = TAIL_LINES) -> str:
    if not path.is_file():
        return "(no log written)"
    with open(path, "rb") as f:
        f.seek(0, os.SEEK_END)
        f.seek(max(0, f.tell() - 200 * lines))
        text = f.read().decode(errors="replace")
    return "\n".join(text.splitlines()[-lines:])


_SOLVE = re.compile(r"Solving for (\w+), Initial residual = ([^,\s]+), Final residual = ([^,\s]+)")
_FPE = re.compile(r"sigFpe::sigHandler|Floating point exception \(core dumped\)")
_COURANT = re.compile(r"Courant Number mean: \S+ max: (\S+)")


def divergence(log_text: str) -> str | None:
    """What in the log shows a blown-up solution (None: nothing): the NaN/FPE trap, a residual
    far beyond any converging run - the initial one, or the final one of a linear solve that
    diverged, which OpenFOAM only bounds and goes on from - or a Courant number."""
    if _FPE.search(log_text):
        return "floating point exception (NaN)"
    for field, initial, final in _SOLVE.findall(log_text):
        for which, value in (("initial", initial), ("final", final)):
            if _bad(float(value), RESIDUAL_LIMIT):
                return f"the {which} residual of {field} is {value}"
    for value in _COURANT.findall(log_text):
        if _bad(float(value), COURANT_LIMIT):
            return f"the Courant number is {value}"
    return None


def _bad(value: float, limit: float) -> bool:
    return math.isnan(value) or value > limit


def diverged(log_text: str) -> bool:
    return divergence(log_text) is not None


def utility(app: str, case: Path, *args: str, log_name: str | None = None) -> Path:
    return run(Command(app=app, case=case, args=tuple(args), log_name=log_name))


def check_available(apps: Sequence[str] = ("blockMesh", "pimpleFoam", "checkMesh")) -> None:
    project_dir()
    for app in apps:
        executable(app)
