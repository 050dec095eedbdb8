"""The ``jethr1`` command line: thin shells around the planner, one module per command.

Exit codes: :data:`jethr1_plan.errors.EXIT_CODES` (docs/contract.md lists them). Progress and messages go to
stderr; ``--json`` prints one JSON document on stdout.
"""

from __future__ import annotations

import errno
import importlib
import os
import sys

import click

from jethr1_plan.cli.common import StdoutError
from jethr1_plan.errors import Jethr1Error, WorkerLost, interrupt_behind, lost_worker_behind, show_notices_as_lines

__all__ = ["entry", "main", "run"]


#: every command: its name → (its module in this package, the click command there). A command's module, and
#: what it imports, is loaded only when that command runs (or ``--help`` lists them all): ``jethr1 plan``
#: pays for no simulator, plotting or viewer library
COMMANDS: dict[str, tuple[str, str]] = {
    "balance-space": ("balance_space", "balance_space"),
    "batch": ("batch", "batch"),
    "compare": ("compare", "compare_cmd"),
    "design": ("design", "design_cmd"),
    "ditch-curve": ("ditch_curve", "ditch_curve_cmd"),
    "plan": ("plan", "plan"),
    "reach": ("reach", "reach_cmd"),
    "replan-steps": ("replan_steps", "replan_steps_cmd"),
    "robot": ("robot", "robot"),
    "route": ("route", "route_cmd"),
    "simulate": ("simulate", "simulate_cmd"),
    "terrain": ("terrain", "terrain"),
    "verify": ("verify", "verify"),
    "view": ("view", "view_cmd"),
    "walk": ("walk", "walk_cmd"),
    "walk-sweep": ("walk", "walk_sweep_cmd"),
    "warm-up": ("warm_up", "warm_up_cmd"),
}


class LazyGroup(click.Group):
    """A click group whose commands (:data:`COMMANDS`) are imported when asked for."""

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted(COMMANDS)

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        if cmd_name not in COMMANDS:
            return None
        module, attr = COMMANDS[cmd_name]
        command: click.Command = getattr(importlib.import_module(f"jethr1_plan.cli.{module}"), attr)
        return command


@click.group(cls=LazyGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="jethr1-plan")
def main() -> None:
    """Plan thrust-assisted steps over ditches for the Jet-HR1 biped (SI units throughout)."""


def run(argv: list[str] | None = None) -> int:
    """Entry point: run the CLI and map expected failures to exit codes (no traceback)."""
    from jethr1_plan.io.input_file import forget_inputs

    forget_inputs()  # this command's inputs are the files it reads
    try:
        rv = main.main(args=argv, prog_name="jethr1", standalone_mode=False)
        sys.stdout.flush()
        if isinstance(rv, int):  # click returns an Exit's code instead of raising it here
            return rv
    except click.exceptions.Exit as exc:
        return _flushed(int(exc.exit_code))
    except click.ClickException as exc:  # usage: one line, as every other bad input
        ctx = getattr(exc, "ctx", None)
        where = f"jethr1 {ctx.command_path.split(' ', 1)[1]}" if ctx is not None and " " in ctx.command_path \
            else "jethr1"
        print(f"{where}: {exc.format_message()}".replace("\n", " "), file=sys.stderr)
        return 2
    except (click.exceptions.Abort, KeyboardInterrupt):
        return _interrupted()
    except StdoutError as exc:
        return _stdout_failed(exc.error)
    except Jethr1Error as exc:
        message = str(exc).replace("\n", " ")
        print(f"jethr1: {message}", file=sys.stderr)
        return _flushed(exc.exit_code)
    except OSError as exc:
        if not _stdout_error(exc):
            raise
        return _stdout_failed(exc)
    except Exception as exc:
        if interrupt_behind(exc) is not None:
            return _interrupted()  # Ctrl-C inside a compiled kernel (a SystemError caused by it)
        if lost_worker_behind(exc) is None:
            raise
        lost = WorkerLost("a worker process")  # a worker pool (loky, Dask) lost one: the out-of-memory killer, a kill
        print(f"jethr1: {lost}; {_written('the worker was lost')}", file=sys.stderr)
        return _flushed(lost.exit_code)
    return 0


def _interrupted() -> int:
    """The one line and exit code of a run stopped by Ctrl-C (130) or SIGTERM (143)."""
    done = _written()
    if _TERMINATED:
        print(f"jethr1: terminated (SIGTERM); workers stopped, {done}", file=sys.stderr)
        return 143
    print(f"jethr1: interrupted; workers stopped, {done}", file=sys.stderr)
    return 130


def _written(before: str = "the interrupt") -> str:
    """What a run stopped by ``before`` leaves: the outputs it completed, else nothing."""
    from jethr1_plan.io.atomic import committed

    done = list(dict.fromkeys(str(p) for p in committed()))
    if not done:
        return "nothing written"
    return f"complete before {before}: {', '.join(done[:5])}{' and more' if len(done) > 5 else ''}; " \
           "nothing half-written"


def _stdout_error(exc: OSError) -> bool:
    """An error writing stdout (a closed pipe, a full device), not one of a file."""
    return isinstance(exc, BrokenPipeError) or (exc.errno in (errno.ENOSPC, errno.EIO, errno.EPIPE)
                                                and exc.filename is None)


def _stdout_failed(exc: OSError) -> int:
    """One line on stderr for a stdout that cannot be written; exit 2. Python's own flush at exit is
    sent to /dev/null so that it does not print a second message."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):
        pass
    from jethr1_plan.io.atomic import committed

    done = committed()
    files = f" (the files are written: {', '.join(dict.fromkeys(map(str, done)))})" if done else ""
    print(f"jethr1: cannot write to stdout: {exc.strerror or exc}{files}", file=sys.stderr)
    return 2


def _flushed(code: int) -> int:
    """``code``, or 2 where stdout cannot take what was printed."""
    try:
        sys.stdout.flush()
    except OSError as exc:
        return _stdout_failed(exc)
    return code


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised as an interrupt so that it unwinds as Ctrl-C does: worker processes are ended,
    staging folders removed, nothing half-written is left."""



_TERMINATED: list[int] = []  # set by SIGTERM: joblib and click turn the interrupt into their own exceptions



def _on_sigterm(signum, frame) -> None:
    _TERMINATED.append(signum)
    raise Terminated()



def entry() -> None:
    import signal

    show_notices_as_lines()
    signal.signal(signal.SIGTERM, _on_sigterm)
    # the worker pools' resource tracker (a process of its own) warns of "leaked semlock objects" when
    # an interrupt ends the pool; it cleans them up all the same: keep its warning off the terminal
    os.environ["PYTHONWARNINGS"] = ",".join(filter(None, (os.environ.get("PYTHONWARNINGS"),
                                                          "ignore:resource_tracker:UserWarning")))
    sys.exit(run())

