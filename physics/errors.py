"""Exceptions of the package.

Every error a user can cause derives from :class:`BeamDamageError` (a
``ValueError``), so the command line turns it into one line on stderr and exit
code 2. Messages name the offending file or parameter, the field and the form
that was expected; they speak in parameter names (``n_elements``), never in
command-line flags. An error about one parameter also carries its name in
``parameter``, which the command line maps to its flag (``--elements``).
"""

__all__ = ["BeamDamageError", "ConfigError", "ConvergenceError", "DiskFullError", "FileFormatError", "OverdampedError",
           "ShapeError"]


class BeamDamageError(ValueError):
    """Base class: bad input or a computation that cannot give a trustworthy answer.

    Attributes
    ----------
    parameter : str or None
        Name of the offending function parameter, when the error is about one.
    """

    def __init__(self, *args, parameter: str | None = None):
        super().__init__(*args)
        self.parameter = parameter


class ShapeError(BeamDamageError):
    """An array has the wrong shape, dtype or non-finite entries."""


class OverdampedError(BeamDamageError):
    """Eigenvalues are real (overdamped or rigid-body) where complex conjugate pairs are required."""


class FileFormatError(BeamDamageError):
    """A data file is missing, truncated, malformed or holds the wrong kind of record."""


class DiskFullError(BeamDamageError):
    """A write ran out of disk space (ENOSPC) or quota (EDQUOT); what existed before is kept as it was."""


#: errno values of a full disk or an exhausted quota.
DISK_FULL_ERRNOS = (28, 122)  # ENOSPC, EDQUOT (Linux)


class ConfigError(BeamDamageError):
    """A configuration file or mapping has a missing, unknown or out-of-range key."""


class ConvergenceError(BeamDamageError, RuntimeError):
    """An iterative procedure (IIRS, Pilkey, ...) did not reach its tolerance.

    Attributes
    ----------
    iterations : int
        Iterations performed before giving up.
    residual : float
        Last relative change of the iterate.
    """

    def __init__(self, message, iterations=0, residual=float("nan"), *, parameter=None):
        super().__init__(message, parameter=parameter)
        self.iterations = iterations
        self.residual = residual
