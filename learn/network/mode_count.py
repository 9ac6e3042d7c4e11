"""How many modes classification needs: one rule for ``classify`` (the modes a measured pair holds) and, up front,
for ``generate`` and ``train`` (the modes a beam's test band holds)."""

from __future__ import annotations

from physics.errors import ConfigError

__all__ = ["MIN_MODES", "mode_count_problem", "require_test_modes"]

#: Modes both tests of a pair must hold: the modal and frequency networks answer on any this many of their modes,
#: and one frequency change alone does not tell where the damage is.
MIN_MODES = 2


def mode_count_problem(n_modes: int, what: str) -> str | None:
    """None when ``n_modes`` modes are enough to classify, else the one-line reason: ``what`` (which modes were
    found where), then the rule."""
    if n_modes >= MIN_MODES:
        return None
    return f"{what}; classify needs at least {MIN_MODES} common modes"


def require_test_modes(test, source: str) -> None:
    """Refuse (ConfigError) a test (:class:`physics.layout.Layout`, None for the thesis's 4 modes) whose band holds
    fewer modes than :func:`mode_count_problem` asks, naming ``source`` and the band."""
    if test is None:
        return
    problem = mode_count_problem(test.n_modes, f"{source}: 'band_hz' [{test.band_hz[0]:g}, {test.band_hz[1]:g}] "
                                               f"holds {test.n_modes} mode(s) the sensors see (mode(s) "
                                               f"{', '.join(map(str, test.modes))} at "
                                               f"{', '.join(f'{f:.4g}' for f in test.frequencies_hz)} Hz)")
    if problem:
        raise ConfigError(f"{problem}: widen 'band_hz' to hold {MIN_MODES} or more bending modes")
