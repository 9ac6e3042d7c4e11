"""The thesis reproduction, the demo, the studies and their reports (``beam-damage experiment NAME``)."""

__all__ = []
