"""A command's own `--help` in click's plain layout, whatever the terminal's width.

typer's rich layout gives every option a row of five columns; beside serve's flag pairs
(`--enforce-comm-constraints / --no-enforce-comm-constraints`) that leaves the help ~20
columns of an 80-column terminal, and rich cuts each longer word (an environment variable's
name, a default) to an ellipsis. click's layout puts such a flag on a line of its own and the
help under it, so every word is shown. The command list of `franka-sim --help` stays rich.
"""

from __future__ import annotations

from typer import _click
from typer.core import MARKUP_MODE_KEY, TyperCommand

# On a wide terminal the help may use up to this many columns (click's own default is 80).
WIDEST = 120


class PlainHelpCommand(TyperCommand):
    """A typer command whose help click lays out; texts are written for rich markup (an
    extra as `franka-sim\\[plot]`), so the escape before a bracket is dropped here."""

    def __init__(self, *args, **kwargs) -> None:
        kwargs["context_settings"] = {"max_content_width": WIDEST,
                                      **(kwargs.get("context_settings") or {})}
        super().__init__(*args, **kwargs)

    def format_help(self, ctx: _click.Context, formatter: _click.HelpFormatter) -> None:
        if not isinstance(ctx.obj, dict):
            ctx.obj = {}
        ctx.obj[MARKUP_MODE_KEY] = None  # the options' "[env var: …]" as plain text
        _click.Command.format_help(self, ctx, formatter)
        formatter.buffer[:] = [part.replace("\\[", "[") for part in formatter.buffer]
