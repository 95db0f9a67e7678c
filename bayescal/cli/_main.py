"""The ``bayescal`` command: the parser of every command, and the one place exceptions become
exit codes.

Every command runs inside one :class:`~bayescal._output.Outputs`: its files appear together
when it succeeds (exit 0, or 1 for a failed health check: the analysis ran and its output
says which check failed), and none of them when it fails. Ctrl-C (SIGINT) and SIGTERM end the
run the same way, with one line and the shell's codes 130 and 143, never a traceback.
"""

import argparse
import contextlib
import os
import signal
import sys

from .._errors import BayescalError
from . import (
    _discover,
    _fleet,
    _multi_position,
    _noise,
    _report,
    _sensors,
    _terms,
    _thermal,
    _two_position,
)
from ._flags import in_flags

INTERNAL_ERROR = 3
COMMANDS = (
    _noise,
    _two_position,
    _thermal,
    _report,
    _multi_position,
    _discover,
    _sensors,
    _terms,
    _fleet,
)


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
    """Keep JAX's compiled functions, and bayescal's traced optimisers
    (:mod:`bayescal.inference._traced`), between runs: a second run neither traces nor
    compiles them. Set through the environment, which JAX reads when it is first imported: a
    command that never needs JAX does not pay for importing it."""
    from pathlib import Path

    root = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    folder = root / "bayescal" / "jax"
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError:
        return
    os.environ.setdefault("JAX_COMPILATION_CACHE_DIR", str(folder))
    os.environ.setdefault("BAYESCAL_TRACE_CACHE", str(root / "bayescal" / "traces"))
    os.environ.setdefault("JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS", "0")


def _command(args) -> str:
    return " ".join(part for part in (args.command, getattr(args, "step", None)) if part)


INTERRUPTED = 128 + signal.SIGINT
TERMINATED = 128 + signal.SIGTERM


class _Terminated(BaseException):
    """SIGTERM, raised where the run is so that it unwinds and cleans up (a BaseException:
    no ``except Exception`` of the library swallows it)."""


_RAISED = {signal.SIGINT: KeyboardInterrupt, signal.SIGTERM: _Terminated}


@contextlib.contextmanager
def _signals_unwind():
    """While the block runs, SIGINT raises KeyboardInterrupt and SIGTERM :class:`_Terminated`
    (in the main thread only; the handlers in place before are restored after). Yields the
    signals received: one that arrives inside a callback Python runs without letting it
    raise (a garbage-collector hook of JAX's, a ``__del__``) is lost as an exception, so the
    block checks the list before it lets its outputs be written."""
    received: list[int] = []
    hook_before = sys.unraisablehook

    def handler(signum, frame):
        received.append(signum)
        raise _RAISED[signum]

    def unraisable(report):
        # Python prints "Exception ignored in ..." and a traceback for the exception such a
        # callback swallows; ours is recorded above and said in one line, so it stays silent.
        if not isinstance(report.exc_value, tuple(_RAISED.values())):
            hook_before(report)

    try:
        previous = {signum: signal.signal(signum, handler) for signum in _RAISED}
    except ValueError:  # not the main thread: leave signals to whoever owns them
        yield received
        return
    sys.unraisablehook = unraisable
    try:
        yield received
    finally:
        sys.unraisablehook = hook_before
        for signum, handler_before in previous.items():
            signal.signal(signum, handler_before)


def main(argv: list[str] | None = None) -> int:
    """Run ``bayescal`` with ``argv`` (the process's arguments when None); the exit code."""
    from .._output import Outputs

    args = build_parser().parse_args(argv)
    _enable_compilation_cache()
    try:
        with _signals_unwind() as received, Outputs():
            code = args.run(args)
            if received:  # a signal swallowed where it arrived: the run does not stand
                raise _RAISED[received[0]]
            return code
    except BayescalError as error:
        message = in_flags(str(error), build_parser())  # the library names its arguments
        print(f"bayescal {_command(args)}: error: {message}", file=sys.stderr)
        return error.exit_code
    except KeyboardInterrupt:
        print(f"bayescal {_command(args)}: interrupted; no output written", file=sys.stderr)
        return INTERRUPTED
    except _Terminated:
        print(f"bayescal {_command(args)}: terminated; no output written", file=sys.stderr)
        return TERMINATED
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
