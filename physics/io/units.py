"""Units of universal-file records: dataset 164 unit factors and axis labels, converted to SI.

Test systems write FRFs and geometry in their own units: a dataset 164 gives
the file's unit system as factors (SI value = file value / factor, for length
and force), and the axis labels of a dataset 58 record often name the unit
outright (``g``, ``mm/s^2``, ``in/s``, ``m/s^2``, ``N``, ``lbf``, or a combined
``g/N``). Labels that name a unit win over the unit system; a label that
cannot be interpreted is refused rather than guessed.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from physics.errors import FileFormatError

__all__ = ["FORCE_UNITS_N", "LENGTH_UNITS_M", "STANDARD_GRAVITY_M_S2", "UnitSystem", "frf_unit_factor",
           "parse_force_unit", "parse_response_unit", "stated_units_factor"]

STANDARD_GRAVITY_M_S2 = 9.80665
#: Length units (in metres) accepted in labels.
LENGTH_UNITS_M = {"m": 1.0, "cm": 1e-2, "mm": 1e-3, "um": 1e-6, "µm": 1e-6, "micron": 1e-6, "in": 0.0254,
                  "inch": 0.0254, "ft": 0.3048}
#: Force units (in newtons) accepted in labels.
FORCE_UNITS_N = {"n": 1.0, "kn": 1e3, "mn": 1e-3, "lbf": 4.4482216152605, "lb": 4.4482216152605,
                 "kgf": STANDARD_GRAVITY_M_S2}
_KIND_OF_POWER = {0: "receptance", 1: "mobility", 2: "accelerance"}
_EMPTY = ("", "none", "null", "-", "unknown")


@dataclass(frozen=True)
class UnitSystem:
    """Unit system of a universal file (dataset 164): SI value = file value / factor."""

    length: float = 1.0
    force: float = 1.0
    description: str = "SI (no dataset 164)"
    from_file: bool = False


def _norm(label) -> str:
    t = str(label or "").strip().lower().replace(" ", "").replace("²", "^2").replace("**", "^")
    t = t.replace("(", "").replace(")", "").replace("[", "").replace("]", "")
    return re.sub(r"/s2$", "/s^2", t)


def parse_response_unit(label):
    """``(kind, factor_to_si)`` of a response unit label, None when the label is empty/NONE.

    ``kind`` is the FRF kind the response gives over a force (displacement ->
    receptance, velocity -> mobility, acceleration -> accelerance); the factor
    converts to m, m/s or m/s^2. Raises :class:`FileFormatError` (without a file
    name; callers add it) when the label names no known unit.
    """
    t = _norm(label)
    if t in _EMPTY:
        return None
    if t in ("g", "gn", "g0"):
        return "accelerance", STANDARD_GRAVITY_M_S2
    m = re.fullmatch(r"([a-zµ]+)(/s(\^2)?|/sec(\^2)?)?", t)
    if m and m.group(1) in LENGTH_UNITS_M:
        power = 0 if not m.group(2) else (2 if m.group(3) or m.group(4) else 1)
        return _KIND_OF_POWER[power], LENGTH_UNITS_M[m.group(1)]
    raise FileFormatError(f"unit label {str(label).strip()!r} is not a displacement, velocity or acceleration "
                          "unit this reader knows (m, mm, in, m/s, mm/s, in/s, m/s^2, mm/s^2, g, ...)")


def parse_force_unit(label):
    """Factor to newtons of a force unit label, None when the label is empty/NONE."""
    t = _norm(label)
    if t in _EMPTY:
        return None
    if t in FORCE_UNITS_N:
        return FORCE_UNITS_N[t]
    raise FileFormatError(f"unit label {str(label).strip()!r} is not a force unit this reader knows "
                          f"({', '.join(k for k in FORCE_UNITS_N if k != 'n')}, N)")


def frf_unit_factor(ordinate_label, denominator_label, system: UnitSystem):
    """Factor taking an FRF record to SI, the kind its labels imply (or None) and a description.

    The ordinate label may carry the force too (``"g/N"``, ``"m/s^2/N"``). Without
    labels the dataset 164 system applies: response lengths in ``1/system.length``
    metres and forces in ``1/system.force`` newtons.

    Returns
    -------
    factor : float
        Multiply the file's FRF values by it to get SI (m/N, m/s/N, m/s^2/N).
    kind : str or None
    found : str
        What the file said, e.g. ``"g/N (axis labels)"`` or ``"mm/N (dataset 164: MM)"``.
    """
    num_text = str(ordinate_label or "").strip()
    den_text = str(denominator_label or "").strip()
    t = _norm(num_text)
    if "/" in t:  # a combined label: the part after the last '/' may be the force
        tail = t.rpartition("/")[2]
        if tail in FORCE_UNITS_N:
            raw_head, _, raw_tail = num_text.rpartition("/")
            num_text = raw_head.strip().strip("()")
            den_text = raw_tail.strip() if _norm(den_text) in _EMPTY else den_text
    num = parse_response_unit(num_text)
    den = parse_force_unit(den_text)
    kind = num[0] if num else None
    num_factor = num[1] if num else 1.0 / system.length
    den_factor = den if den is not None else 1.0 / system.force
    if num or den is not None:
        found = f"{num_text.strip() if num else 'length/' + system.description}/" \
                f"{den_text.strip() if den is not None else 'force/' + system.description} (axis labels)"
    elif system.from_file:
        found = f"file units of dataset 164 ({system.description})"
    else:
        found = "no unit labels and no dataset 164: SI assumed"
    return num_factor / den_factor, kind, found


def stated_units_factor(units, kind: str, where: str) -> float:
    """The factor taking FRFs of ``kind`` whose file states ``units`` (a CSV's ``# units:`` line, an NPZ's ``units``;
    ``"mm/N"``, ``"g/N"``, ``"in/s/lbf"``) to SI; 1 for none stated. A unit this reader does not know, or one of
    another kind (``g/N`` for a receptance), is refused naming ``where`` (the file and its field)."""
    if _norm(units) in _EMPTY:
        return 1.0
    try:
        factor, implied, _ = frf_unit_factor(units, "", UnitSystem())
    except FileFormatError as exc:
        raise FileFormatError(f"{where}: {exc}; expected a response unit over a force unit (m/N, mm/N, g/N, "
                              "m/s/N, ...)") from None
    if implied is None or "/" not in _norm(units):
        raise FileFormatError(f"{where}: {str(units).strip()!r} is not a response unit over a force unit (m/N, "
                              "mm/N, g/N, m/s/N, ...)")
    if implied != kind:
        raise FileFormatError(f"{where}: {str(units).strip()!r} is a unit of {implied}, but the FRFs are {kind}")
    return factor
