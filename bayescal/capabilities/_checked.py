"""The checks every capability's result carries: what failed, and a ``check()`` that raises."""

from collections.abc import Sequence
from typing import Self

from .._errors import HealthCheckError


class Checked:
    """A result whose posterior (and fit) passed or failed its checks.

    A subclass defines :attr:`failures` (each failed check, in words) and
    ``_check_subject`` (what the message of :meth:`check` names first); :attr:`passed` is
    that nothing failed unless the subclass says more.
    """

    _check_subject: str = ""

    @property
    def failures(self) -> Sequence[str]:
        """Each failed check, in words (empty when every check passed)."""
        raise NotImplementedError

    @property
    def passed(self) -> bool:
        """Whether every check passed."""
        return not self.failures

    def check(self) -> Self:
        """Raise :class:`~bayescal.HealthCheckError` naming the failed checks, if any.

        Returns
        -------
        Self
            This result, unchanged, when every check passed, so that the call chains
            (``result = capability(...).check()``).

        Raises
        ------
        HealthCheckError
            A check failed; the message names each.
        """
        if not self.passed:
            prefix = f"{self._check_subject}: " if self._check_subject else ""
            raise HealthCheckError(prefix + "; ".join(self.failures))
        return self
