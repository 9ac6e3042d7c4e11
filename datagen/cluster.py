"""A Dask distributed cluster's client from the address a user gives (``--scheduler`` of ``generate`` and
``monitor``): the address's form checked before Dask is imported, every refusal one line."""

from __future__ import annotations

from physics.errors import BeamDamageError

__all__ = ["SCHEDULER_SCHEMES", "connect"]

#: Address schemes of Dask's communication layer (``scheme://host:port``).
SCHEDULER_SCHEMES = ("tcp", "tls", "inproc", "ws", "wss", "ucx")


def connect(scheduler: str):
    """A Dask client of ``scheduler`` (``scheme://host:port``, or ``host:port`` for ``tcp``), or a one-line
    :class:`~physics.errors.BeamDamageError` naming ``--scheduler``: a malformed address, the ``dask`` extra not
    installed, or no scheduler answering there."""
    host, _, port = scheduler.rpartition(":")
    if "://" not in scheduler and host and port.isdigit():
        scheduler = f"tcp://{scheduler}"                 # host:port, Dask's default scheme
    scheme, sep, rest = scheduler.partition("://")
    if not sep or scheme not in SCHEDULER_SCHEMES or not rest.strip():
        raise BeamDamageError(f"scheduler {scheduler!r}: expected an address scheme://host:port with a scheme in "
                              f"{', '.join(SCHEDULER_SCHEMES)}, such as tcp://host:8786", parameter="scheduler")
    try:
        from distributed import Client
    except ImportError:
        raise BeamDamageError("--scheduler needs the optional extra: pip install 'beam-damage[dask]'",
                              parameter="scheduler") from None
    try:
        return Client(scheduler)
    except (ValueError, TypeError, OSError, TimeoutError) as exc:
        msg = " ".join(str(exc).split()) or type(exc).__name__
        raise BeamDamageError(f"scheduler {scheduler!r}: {msg}; expected an address such as tcp://host:8786",
                              parameter="scheduler") from None
