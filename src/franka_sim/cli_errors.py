"""How `franka-sim` says a command line is wrong: one line, not typer's box.

typer draws a usage error in a box of several lines wrapped at the terminal's width, which a
log collector, `docker logs` or a CI log then holds in pieces; and a value from a FRANKA_SIM_*
variable is named by its flag alone. `run` says each on one line
(`franka-sim serve: Invalid value for --inject (from FRANKA_SIM_INJECT): …`)."""

from __future__ import annotations

import typer


def run(app) -> None:
    """Run the typer `app`; a command line it refuses is said on one line (a log collector,
    `docker logs` and CI keep it whole), naming the variable a value came from."""
    usage_error = _click_class(typer.BadParameter, "UsageError")
    try:
        code = app(standalone_mode=False)
    except usage_error as exc:
        if exc.format_message().strip():  # (none after the help a bare `franka-sim` shows)
            typer.echo(_one_line(exc), err=True)
        raise SystemExit(exc.exit_code) from None
    except _click_class(typer.BadParameter, "ClickException") as exc:
        typer.echo(f"franka-sim: {' '.join(exc.format_message().split())}", err=True)
        raise SystemExit(exc.exit_code) from None
    except typer.Abort:
        typer.echo("Aborted!", err=True)
        raise SystemExit(1) from None
    raise SystemExit(code if isinstance(code, int) else 0)


def _click_class(known: type, name: str) -> type:
    """click's exception `name`, a base of `known` (typer 0.28 carries its own click, older
    ones the package)."""
    return next(cls for cls in known.__mro__ if cls.__name__ == name)


def _one_line(exc) -> str:
    """"franka-sim serve: Invalid value for --inject (FRANKA_SIM_INJECT): … (see 'franka-sim
    serve --help')"."""
    ctx = exc.ctx
    message = " ".join(exc.format_message().split())
    if ctx is None:
        return f"franka-sim: {message}"
    hint = getattr(exc, "param_hint", None)
    param = getattr(exc, "param", None) or next(
        (p for p in ctx.command.params if hint and hint in getattr(p, "opts", ())), None)
    if param is not None and getattr(ctx.get_parameter_source(param.name), "name", "") == \
            "ENVIRONMENT":
        flag = hint or param.opts[0]
        message = message.replace(f"{flag}:", f"{flag} (from {param.envvar}):", 1)
        message = message.replace(f"'{flag}':", f"'{flag}' (from {param.envvar}):", 1)
    return f"{ctx.command_path}: {message} (see '{ctx.command_path} --help')"
