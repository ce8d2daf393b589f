"""Entry point of the ``dyncatch`` console script.

Every sub-command is a frozen dataclass read by tyro (its fields are the flags, their
docstrings the help), registered in ``dyncatch.cli.commands.COMMANDS``.
"""

from __future__ import annotations

import dataclasses
import sys

from dyncatch.cli.commands import COMMANDS, Command, Group
from dyncatch.sim.validate import ConfigError
from dyncatch.utils.jax_setup import setup_jax


def _group_stub(name: str, group: Group) -> type:
    """A flag-less dataclass standing for a group in the top-level help."""
    doc = f"{group.doc} Sub-commands: {', '.join(group.commands)}."
    return dataclasses.make_dataclass(name.capitalize() + "Group", [], namespace={"__doc__": doc})


def parse(argv: list[str]) -> tuple[Command, object]:
    import tyro

    if argv and isinstance(COMMANDS.get(argv[0]), Command):
        command: Command = COMMANDS[argv[0]]  # type: ignore[assignment]
        prog = f"dyncatch {argv[0]}"
        cmd = tyro.cli(command.spec, args=argv[1:], prog=prog)
        if command.refine is not None:
            cmd = tyro.cli(command.spec, args=argv[1:], prog=prog, default=command.refine(cmd))
        return command, cmd
    if argv and isinstance(COMMANDS.get(argv[0]), Group):
        group: Group = COMMANDS[argv[0]]  # type: ignore[assignment]
        specs = {name: c.spec for name, c in group.commands.items()}
        cmd = tyro.extras.subcommand_cli_from_dict(
            specs, args=argv[1:], prog=f"dyncatch {argv[0]}", description=group.doc
        )
        chosen = next(c for c in group.commands.values() if isinstance(cmd, c.spec))
        return chosen, cmd
    specs = {
        name: (c.spec if isinstance(c, Command) else _group_stub(name, c))
        for name, c in COMMANDS.items()
    }
    cmd = tyro.extras.subcommand_cli_from_dict(specs, args=argv, prog="dyncatch")
    chosen = next(
        c for c in COMMANDS.values() if isinstance(c, Command) and isinstance(cmd, c.spec)
    )
    return chosen, cmd


def main(argv: list[str] | None = None) -> int:

    try:
        command, cmd = parse(sys.argv[1:] if argv is None else argv)
        setup_jax()
        command.run(cmd)
    except (ConfigError, FileNotFoundError, ValueError) as err:
        print(f"dyncatch: error: {err}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
