"""One rule for every command: bad input is one line on stderr and exit code 2; Ctrl-C exit 130.

`clear_errors` maps a `HriplanError` to `error: ...`; `OneLineErrors` does the same for the
command line itself (a missing argument, an unknown option) and makes Ctrl-C stop at once, even
inside OMPL's solve, which never returns to Python's own KeyboardInterrupt handling; the process
of a command line ends as soon as its command is done (`cli/quick_exit.py`).
"""

from __future__ import annotations

import functools
import os
import signal
import sys
import threading
from collections.abc import Callable, Sequence
from typing import Any, TypeVar

import typer
from typer._click import Context
from typer._click import exceptions as click_errors  # typer vendors click: its exceptions live here
from typer.core import TyperGroup

from hriplan import HriplanError
from hriplan.cli.outputs import remove_partial_outputs
from hriplan.cli.quick_exit import exit_now
from hriplan.collector import collector_paused_while_importing

F = TypeVar("F", bound=Callable)
INTERRUPTED = 130  # 128 + SIGINT, what a shell reports for Ctrl-C


def clear_errors(func: F) -> F:
    """Turn a user error into `error: ...` and exit code 2 instead of a traceback."""

    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        try:
            return func(*args, **kwargs)
        except HriplanError as exc:
            typer.echo(f"error: {exc}", err=True)
            raise typer.Exit(2) from None

    return wrapper  # type: ignore[return-value]


def _interrupted(signum: int, frame: object) -> None:
    """Ctrl-C: drop what is half written and leave now (long C++ stages would not see an exception)."""
    remove_partial_outputs()
    sys.stderr.write("interrupted\n")
    sys.stderr.flush()
    os._exit(INTERRUPTED)


class OneLineErrors(TyperGroup):
    """The root command: usage errors as one line, Ctrl-C as exit 130 with nothing half written."""

    def make_context(
        self, info_name: str | None, args: list[str], parent: Context | None = None, **extra: Any
    ) -> Context:
        """Parse the root's options; typer's conversion of them imports pydantic (not for `--help`)."""
        with collector_paused_while_importing():
            return super().make_context(info_name, args, parent, **extra)

    def main(
        self,
        args: Sequence[str] | None = None,
        prog_name: str | None = None,
        complete_var: str | None = None,
        standalone_mode: bool = True,
        **extra: Any,
    ) -> Any:
        on_main_thread = threading.current_thread() is threading.main_thread()
        previous = signal.signal(signal.SIGINT, _interrupted) if on_main_thread else None
        try:
            code = super().main(args, prog_name, complete_var, standalone_mode=False, **extra)
        except click_errors.NoArgsIsHelpError as exc:
            exc.show()
            code = exc.exit_code
        except click_errors.ClickException as exc:
            where = f" (see '{exc.ctx.command_path} --help')" if getattr(exc, "ctx", None) else ""
            typer.echo(f"error: {exc.format_message()}{where}", err=True)
            code = exc.exit_code
        except typer.Abort:
            typer.echo("interrupted", err=True)
            code = INTERRUPTED
        finally:
            if on_main_thread:
                signal.signal(signal.SIGINT, previous)
        if not standalone_mode:
            return code
        code = code if isinstance(code, int) else 0
        if args is None:  # the process's own command line (click read sys.argv): nothing is left to run
            exit_now(code)
        sys.exit(code)
