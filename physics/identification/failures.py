"""An identification that fails on one record's numbers: which exceptions say so, and the one line that reports it.

``classify`` (:func:`learn.pairs.measured.identify_modes`, :func:`~learn.pairs.measured.identify_band`) and
``monitor`` (:func:`learn.monitor.identification.identify_test`) identify each record inside
:func:`identification_failure`, so both turn the same exceptions into the same report.
"""

from __future__ import annotations

from contextlib import contextmanager

import numpy as np

from physics.errors import BeamDamageError

__all__ = ["PER_RECORD_ERRORS", "exception_text", "identification_failure"]

#: Exceptions of an identification that make one record "not identified" (its numbers, not the program: a singular
#: or ill-conditioned system, an SVD that does not converge, an overflow, an array shorter than a method's window, a
#: NaN a library refuses). Others (TypeError, KeyError, AttributeError...) are defects of the program and are raised
#: as they are. The project's own errors (:class:`~physics.errors.BeamDamageError`, a ``ValueError`` too) are not
#: converted: :func:`identification_failure` lets them pass unchanged, class and ``parameter`` included.
PER_RECORD_ERRORS = (np.linalg.LinAlgError, ArithmeticError, IndexError, ValueError, RuntimeError)


def exception_text(exc: BaseException) -> str:
    """``"IndexError: index 3 is out of bounds"``: the class (not for the project's own errors) and the message on
    one line."""
    text = " ".join(str(exc).split())
    if isinstance(exc, BeamDamageError):
        return text
    return type(exc).__name__ + (f": {text}" if text else "")


@contextmanager
def identification_failure(what: str):
    """Within the block, an exception of :data:`PER_RECORD_ERRORS` becomes a :class:`BeamDamageError` of one line,
    ``"{what} failed ({class}: {message})"``; a :class:`BeamDamageError` raised there passes as it is (an input the
    user must correct keeps its class and its ``parameter``, so the command line names the flag, exit code 2).

    Parameters
    ----------
    what : str
        The identification and its record, e.g. ``"test_003.npz: output-only identification (ssi)"``.
    """
    try:
        yield
    except BeamDamageError:
        raise
    except PER_RECORD_ERRORS as exc:
        raise BeamDamageError(f"{what} failed ({exception_text(exc)})") from None
