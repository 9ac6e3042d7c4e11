"""Modal-data test files (``{"natural_frequencies_hz": [...]}`` JSON), one per test of a series."""

import json

__all__ = ["write_modal_series"]


def write_modal_series(root, frequencies_hz, prefix: str = "t") -> list:
    """The paths (str) of one JSON file per row of ``frequencies_hz`` (tests x modes, Hz) written into ``root``,
    named ``{prefix}00.json``, ``{prefix}01.json``, ... in the rows' order."""
    files = []
    for k, f in enumerate(frequencies_hz):
        path = root / f"{prefix}{k:02d}.json"
        path.write_text(json.dumps({"natural_frequencies_hz": [float(v) for v in f]}))
        files.append(str(path))
    return files
