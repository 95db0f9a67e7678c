"""The ``bayescal`` command: the parser of every command, and the one place exceptions become
exit codes.

Every command runs inside one :class:`~bayescal._output.Outputs`: its files appear together
when it succeeds (exit 0, or 1 for a failed health check: the analysis ran and its output
says which check failed), and none of them when it fails. Ctrl-C (SIGINT) and SIGTERM end the
run the same way, with one line and the shell's codes 130 and 143, never a traceback.
"""

import _thread
import argparse
import logging
import os
import signal
import sys
import threading

from .._errors import BayescalError
from ._flags import in_flags

INTERNAL_ERROR = 3


class _Parser(argparse.ArgumentParser):
    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message}; see '{self.prog} --help'\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="bayescal",
        description="Bayesian uncertainty quantification of inertial sensors. Run "
        "'bayescal demo' to try it.",
    )
    # Imported here, not at the module's top: the command line's signal handler is in place
    # before (main), so that a Ctrl-C while they load ends as quietly as one later.
    from . import (
        _discover,
        _export_filter,
        _fleet,
        _multi_position,
        _noise,
        _plan,
        _report,
        _sensors,
        _terms,
        _thermal,
        _two_position,
    )

    commands = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    for command in (
        _noise,
        _two_position,
        _thermal,
        _report,
        _multi_position,
        _discover,
        _sensors,
        _terms,
        _plan,
        _export_filter,
        _fleet,
    ):
        command.add_parser(commands)
    return parser


def _command(args) -> str:
    return " ".join(part for part in (args.command, getattr(args, "step", None)) if part)


INTERRUPTED = 128 + signal.SIGINT
TERMINATED = 128 + signal.SIGTERM


class _Terminated(BaseException):
    """SIGTERM, raised where the run is so that it unwinds and cleans up (a BaseException:
    no ``except Exception`` of the library swallows it)."""


_RAISED = {signal.SIGINT: KeyboardInterrupt, signal.SIGTERM: _Terminated}
_SAID = {signal.SIGINT: ("interrupted", INTERRUPTED), signal.SIGTERM: ("terminated", TERMINATED)}


def _initialising_extension(frame) -> bool:
    """Whether ``frame`` runs inside the initialisation of a C extension module (or in Python
    code it calls): an exception there can abort the process (jaxlib's modules, built with
    nanobind, treat one raised while they create their types as fatal)."""
    from importlib.machinery import ExtensionFileLoader

    while frame is not None:
        code = frame.f_code
        if (
            code.co_name in ("create_module", "exec_module")
            and code.co_filename == "<frozen importlib._bootstrap_external>"
            and isinstance(frame.f_locals.get("self"), ExtensionFileLoader)
        ):
            return True
        frame = frame.f_back
    return False


class _Signals:
    """The one handler of SIGINT and SIGTERM for a whole run (in the main thread; elsewhere
    signals are left to whoever owns them).

    While the run works, a signal raises KeyboardInterrupt or :class:`_Terminated` where the
    run is — in JAX, emcee, Dask or a writer — so that it unwinds through every ``finally``
    and ``with``: the staged outputs are removed (:class:`~bayescal._output.Outputs`, which
    holds signals while it moves or removes files), a spooled channel and a Dask cluster
    closed. Inside a C extension's initialisation it waits until that is done (an exception
    there can abort the process), checking again every 20 ms. It raises once: a second
    signal while the run unwinds is recorded, not raised into the cleanup. Once the run has settled
    (:meth:`settle`) — its work done and its outputs about to move into place, or its end
    being reported — a signal is only recorded.

    While a signal has been received, Python's reports of exceptions nobody could catch
    (in a ``__del__``, a garbage-collector hook of JAX's, a thread, an ``atexit`` function)
    and the libraries' logging are silent: they are the interruption's echoes, and the run's
    one line says it.
    """

    def __init__(self):
        self.received: list[int] = []
        self._state = "working"  # then "unwinding" (a signal raised), or "settled"
        self._again = False
        self._before: dict = {}
        self._hooks = (sys.unraisablehook, threading.excepthook)
        self._logging_disabled = logging.root.manager.disable

    def _handle(self, signum, frame):
        if self._again:
            self._again = False  # the same signal, raised again (_later)
        else:
            if not self.received:
                # Libraries log the interruption's echoes as errors (Dask's scheduler on its
                # workers' closed connections, asyncio's callbacks): the one line says it.
                logging.disable(logging.CRITICAL)
            self.received.append(signum)
        if self._state != "working":
            return
        if _initialising_extension(frame):
            self._later(signum)
            return
        self._state = "unwinding"
        raise _RAISED[signum]

    def _later(self, signum: int) -> None:
        """Handle ``signum`` again 20 ms from now, where the run is by then."""
        self._again = True
        again = threading.Timer(0.02, _thread.interrupt_main, (signum,))
        again.daemon = True
        again.start()

    def _unraisable(self, report):
        # Python would print "Exception ignored in ..." and a traceback: for the signal's
        # exception swallowed by a callback that may not raise, or an error the interruption
        # caused. A swallowed signal (JAX's garbage-collector hook runs often while modules
        # load) is raised again moments later: else the run went on to its end.
        if isinstance(report.exc_value, tuple(_RAISED.values())):
            if self._state == "unwinding":
                self._state = "working"
                self._later(self.received[-1])
        elif not self.received:
            self._hooks[0](report)

    def _thread_failed(self, arguments):
        if not self.received:
            self._hooks[1](arguments)

    def install(self) -> "_Signals":
        try:
            self._before = {signum: signal.signal(signum, self._handle) for signum in _RAISED}
        except ValueError:  # not the main thread
            return self
        sys.unraisablehook, threading.excepthook = self._unraisable, self._thread_failed
        return self

    def stop(self) -> None:
        """From here a signal is only recorded."""
        self._state = "settled"

    def settle(self) -> None:
        """:meth:`stop`, and raise a signal received before and swallowed where it arrived
        (in a callback that may not raise)."""
        self.stop()
        if self.received:
            raise _RAISED[self.received[0]]

    def restore(self) -> None:
        """The handlers, hooks and logging in place before :meth:`install`."""
        self.stop()
        if self.received:
            logging.disable(self._logging_disabled)
        for signum, handler in self._before.items():
            signal.signal(signum, handler)
        if self._before:
            sys.unraisablehook, threading.excepthook = self._hooks
        self._before = {}


def _run(args, signals: _Signals) -> int:
    from .._output import Outputs

    with Outputs():
        code = args.run(args)
        signals.settle()  # the outputs move into place as the block ends
    return code


def _report(error: BaseException, signals: _Signals, command: str | None) -> int:
    """The one line and the exit code of a run that ended with ``error``: a signal's, when
    one came (whatever the error it caused inside a library), else the error's."""
    prefix = f"bayescal {command}" if command else "bayescal"
    signum = signals.received[0] if signals.received else None
    if signum is None and isinstance(error, (KeyboardInterrupt, _Terminated)):
        signum = signal.SIGINT if isinstance(error, KeyboardInterrupt) else signal.SIGTERM
    if signum is not None:
        word, code = _SAID[signum]
        print(f"{prefix}: {word}; no output written", file=sys.stderr)
        return code
    if isinstance(error, BayescalError):
        message = in_flags(str(error), build_parser())  # the library names its arguments
        print(f"{prefix}: error: {message}", file=sys.stderr)
        return error.exit_code
    if os.environ.get("BAYESCAL_DEBUG"):
        raise error
    print(
        f"{prefix}: internal error (a bug, please report it): "
        f"{type(error).__name__}: {error}; set BAYESCAL_DEBUG=1 for the traceback",
        file=sys.stderr,
    )
    return INTERNAL_ERROR


def main(argv: list[str] | None = None) -> int:
    """Run ``bayescal`` with ``argv`` (the process's arguments when None); the exit code.

    The signal handler (:class:`_Signals`) is in place before the commands are imported and
    the arguments parsed. Run for the process (``argv`` None) it stays, recording only: a
    signal after the run has ended changes nothing (until the interpreter's last teardown,
    where Python has put back the default handlers). Run with ``argv`` (in-process, as the
    tests do), the handlers before are restored."""
    signals = _Signals().install()
    command = None
    try:
        try:
            args = build_parser().parse_args(argv)
            command = _command(args)
            return _run(args, signals)
        except SystemExit:  # argparse: --help, or a usage error with its message (exit 2)
            raise
        except BaseException as error:
            signals.stop()
            return _report(error, signals, command)
    except (KeyboardInterrupt, _Terminated):  # the first signal, while an error was reported
        return _report(_RAISED[signals.received[0]](), signals, command)
    finally:
        if argv is None:
            signals.stop()
        else:
            signals.restore()


if __name__ == "__main__":
    sys.exit(main())
