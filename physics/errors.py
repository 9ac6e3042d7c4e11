"""Exceptions of the package.

Every error a user can cause derives from :class:`BeamDamageError` (a
``ValueError``), so the command line turns it into one line on stderr and exit
code 2. Messages name the offending file or argument, the field and the form
that was expected.
"""


class BeamDamageError(ValueError):
    """Base class: bad input or a computation that cannot give a trustworthy answer."""


class ShapeError(BeamDamageError):
    """An array has the wrong shape, dtype or non-finite entries."""


class OverdampedError(BeamDamageError):
    """Eigenvalues are real (overdamped or rigid-body) where complex conjugate pairs are required."""


class FileFormatError(BeamDamageError):
    """A data file is missing, truncated, malformed or holds the wrong kind of record."""


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

    def __init__(self, message, iterations=0, residual=float("nan")):
        super().__init__(message)
        self.iterations = iterations
        self.residual = residual
