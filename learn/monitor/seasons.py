"""Whether a dated baseline period covers the seasons, which the statistics of the environment judge against it."""

from __future__ import annotations

from datetime import datetime

__all__ = ["SEASONS_DAYS", "covers_seasons", "season_warning"]

#: A baseline period of dated tests shorter than this (days) does not cover the seasons.
SEASONS_DAYS = 330.0


def season_warning(times, time_values, n_baseline: int, names) -> str | None:
    """The warning for environmental statistics judged against a baseline period of dated tests (``times`` ISO
    dates, ``time_values`` days) that spans less than :data:`SEASONS_DAYS` while later tests lie beyond it: the
    seasons it did not see move the environmental scores and the shift about the baseline mean as a change would
    (None otherwise)."""

    env = [nm for nm in names if nm in ("environment", "shift")]
    span = _baseline_span_days(times, time_values, n_baseline) if env else None
    if span is None or span >= SEASONS_DAYS or time_values[-1] - time_values[0] <= span:
        return None
    return (f"the baseline period spans {span:.0f} days: the {' and '.join(env)} statistics judge the environment "
            "against it, and the seasons it did not see move them as a change would (reported as 'change or unseen "
            "conditions' beyond the baseline's environment); cover a year, give the measured conditions (columns "
            "such as temperature_c in --conditions) or leave them out (--statistics residual)")


def covers_seasons(times, time_values, n_baseline: int) -> bool:
    """Whether the baseline period is known to cover the seasons: dated tests (``times`` ISO dates, ``time_values``
    days) whose first ``n_baseline`` span at least :data:`SEASONS_DAYS`."""
    span = _baseline_span_days(times, time_values, n_baseline)
    return span is not None and span >= SEASONS_DAYS


def _baseline_span_days(times, time_values, n_baseline: int) -> float | None:
    """Days between the first and the last baseline test of a dated series (``times`` ISO dates, ``time_values``
    days); None for a series without dates."""
    if times is None or not len(times) or times[0] is None:
        return None
    try:
        datetime.fromisoformat(str(times[0]).strip())
    except ValueError:
        return None
    return float(time_values[n_baseline - 1] - time_values[0])
