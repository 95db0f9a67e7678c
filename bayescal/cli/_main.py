"""The ``bayescal`` command: the parser of every command, and the one place exceptions become
exit codes."""

import argparse
import os
import sys

from .._errors import BayescalError
from . import _discover, _fleet, _multi_position, _noise, _report, _sensors, _thermal, _two_position

INTERNAL_ERROR = 3
COMMANDS = (_noise, _two_position, _thermal, _report, _multi_position, _discover, _sensors, _fleet)


class _Parser(argparse.ArgumentParser):
    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message}; see '{self.prog} --help'\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="bayescal",
        description="Bayesian uncertainty quantification of inertial sensors. Run "
        "'bayescal demo' to try it.",
    )
    commands = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    for command in COMMANDS:
        command.add_parser(commands)
    return parser


def _enable_compilation_cache() -> None:
    """Keep JAX's compiled functions between runs (a second run starts in a second). Set
    through the environment, which JAX reads when it is first imported: a command that never
    needs JAX does not pay for importing it."""
    from pathlib import Path

    root = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    folder = root / "bayescal" / "jax"
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError:
        return
    os.environ.setdefault("JAX_COMPILATION_CACHE_DIR", str(folder))
    os.environ.setdefault("JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS", "0.2")


def _command(args) -> str:
    return " ".join(part for part in (args.command, getattr(args, "step", None)) if part)


def main(argv: list[str] | None = None) -> int:
    """Run ``bayescal`` with ``argv`` (the process's arguments when None); the exit code."""
    args = build_parser().parse_args(argv)
    _enable_compilation_cache()
    try:
        return args.run(args)
    except BayescalError as error:
        print(f"bayescal {_command(args)}: error: {error}", file=sys.stderr)
        return error.exit_code
    except Exception as error:
        if os.environ.get("BAYESCAL_DEBUG"):
            raise
        print(
            f"bayescal {_command(args)}: internal error (a bug, please report it): "
            f"{type(error).__name__}: {error}; set BAYESCAL_DEBUG=1 for the traceback",
            file=sys.stderr,
        )
        return INTERNAL_ERROR


if __name__ == "__main__":
    sys.exit(main())
