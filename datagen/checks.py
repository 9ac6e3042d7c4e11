"""Checks of configuration values: one-line :class:`physics.errors.ConfigError` naming the dotted key."""

from __future__ import annotations

import math

from physics.errors import ConfigError

__all__ = ["number", "value_range"]


def value_range(key, v, *, lo=None, hi=None, integer=False, allow_empty=False):
    """``v`` as a range ``[low, high]`` of two numbers within ``[lo, hi]`` (ints with ``integer``; ``[]`` with
    ``allow_empty``); ConfigError naming the dotted ``key`` otherwise."""
    if allow_empty and isinstance(v, list) and len(v) == 0:
        return []
    if not (isinstance(v, list) and len(v) == 2 and all(isinstance(x, (int, float)) and not isinstance(x, bool)
                                                           for x in v)):
        raise ConfigError(f"config key {key!r} must be a range [low, high] of two numbers, got {v!r}")
    a, b = v
    if integer and not all(float(x).is_integer() for x in v):
        raise ConfigError(f"config key {key!r} must hold integers, got {v!r}")
    if not (math.isfinite(a) and math.isfinite(b)) or a > b:
        raise ConfigError(f"config key {key!r} must satisfy low <= high (finite), got {v!r}")
    if lo is not None and a < lo or hi is not None and b > hi:
        raise ConfigError(f"config key {key!r} must lie within [{lo}, {hi}], got {v!r}")
    return [int(a), int(b)] if integer else [float(a), float(b)]


def number(key, v, *, lo=None, hi=None, integer=False, strict_lo=False):
    """``v`` as a finite number in ``[lo, hi]`` (``(lo, hi]`` with ``strict_lo``); ConfigError naming ``key``."""
    if isinstance(v, bool) or not isinstance(v, (int, float)) or (integer and not float(v).is_integer()):
        raise ConfigError(f"config key {key!r} must be {'an integer' if integer else 'a number'}, got {v!r}")
    if not math.isfinite(v):
        raise ConfigError(f"config key {key!r} must be finite, got {v!r}")
    if lo is not None and (v <= lo if strict_lo else v < lo) or hi is not None and v > hi:
        raise ConfigError(f"config key {key!r} must lie in {'(' if strict_lo else '['}{lo}, {hi}], got {v!r}")
    return int(v) if integer else float(v)
