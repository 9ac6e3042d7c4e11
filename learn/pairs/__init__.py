"""Measured pairs classified (``classify``): their modes, a test's modal noise, the normal variation, the network's
inputs, the verdict (docs/contributing.md lists the modules). Import the modules."""

__all__: list[str] = []
