"""Errors that reach a user, each with the exit code the command line gives it."""

import errno
from functools import partial


class BayescalError(Exception):
    """Base of every error bayescal raises on purpose; ``exit_code`` is the CLI status."""

    exit_code = 2


class InputError(BayescalError, ValueError):
    """Bad input: a file, column or argument that bayescal cannot use as given.

    The message is one line that names what is wrong (file, column or argument), where
    (row or time), and what to do about it.
    """

    exit_code = 2

    def __init__(
        self,
        problem: str,
        *,
        source: str | None = None,
        column: str | None = None,
        fix: str | None = None,
    ):
        self.problem = problem
        self.source = source
        self.column = column
        self.fix = fix
        super().__init__(self._compose())

    def _compose(self) -> str:
        where = ": ".join(
            part
            for part in (self.source, f"column '{self.column}'" if self.column else None)
            if part
        )
        text = f"{where}: {self.problem}" if where else self.problem
        if self.fix:
            text = f"{text}; {self.fix}"
        return text


class MissingFileError(InputError, FileNotFoundError):
    """A file that does not exist: bad input (the command line exits 2, as for any
    :class:`InputError`) and, to Python, a :class:`FileNotFoundError` whose ``filename`` is
    missing file (``errno`` ENOENT), so that ``except FileNotFoundError`` catches it."""

    def __init__(
        self,
        problem: str,
        *,
        source: str | None = None,
        column: str | None = None,
        fix: str | None = "check the path",
        filename: str | None = None,
    ):
        super().__init__(problem, source=source, column=column, fix=fix)
        self.errno = errno.ENOENT
        self.filename = filename or source

    def __str__(self) -> str:
        # The composed message: OSError's "[Errno 2] ..." would drop the problem and the fix.
        return self.args[0]

    def __reduce__(self):
        # Rebuilt from its parts (a Dask worker's error travels pickled), not from its text.
        fields = {"source": self.source, "column": self.column, "fix": self.fix}
        return partial(type(self), self.problem, filename=self.filename, **fields), ()


class HealthCheckError(BayescalError, RuntimeError):
    """An analysis ran but its result failed a health check (exit code 1)."""

    exit_code = 1
