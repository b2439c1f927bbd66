"""The command line builds only the command it runs.

typer turns every registered command into a click command (reading each function's signature
and type hints) before it parses anything: for hriplan's 20 commands and two groups that is about
35 ms of CPU in every process, 4 % of the demo's `plan`. When the first argument is exactly a
command's or a group's name, nothing but that command (and the root's own options) can be
reached, so the root is built with that one alone: the same click command, reached by the same
path, gives the same parsing, help and errors. Anything else (`--help`, `--version`, no
argument, a mistyped name whose error lists the commands) builds them all, as typer does.
"""

from __future__ import annotations

import copy
import sys
from typing import TYPE_CHECKING, Any

import typer
from typer.main import get_command_name

if TYPE_CHECKING:
    from typer.models import CommandInfo


class OneCommandTyper(typer.Typer):
    """A `typer.Typer` whose call builds only the command its first argument names."""

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        argv = kwargs["args"] if "args" in kwargs else args[0] if args else sys.argv[1:]
        return typer.Typer.__call__(self.narrowed_to(list(argv or [])[:1]), *args, **kwargs)

    def narrowed_to(self, first: list[str]) -> typer.Typer:
        """This app with only the command or group named `first[0]`; itself if none is (or no name)."""
        commands = [c for c in self.registered_commands if first == [_command_name(c)]]
        groups = [g for g in self.registered_groups if first == [g.name]]
        if len(commands) + len(groups) != 1:
            return self
        narrowed = copy.copy(self)
        narrowed.registered_commands, narrowed.registered_groups = commands, groups
        return narrowed


def _command_name(info: CommandInfo) -> str:
    """The name typer gives a command: its own, or its function's with dashes."""
    return info.name or get_command_name(info.callback.__name__)
