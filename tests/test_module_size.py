"""Small modules named after one concept: no module of the packages above :data:`MAX_LINES` lines."""

from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("physics", "datagen", "learn", "experiments")
MAX_LINES = 600


def test_no_module_is_above_the_line_limit():
    sizes = {str(p.relative_to(ROOT)): len(p.read_text(encoding="utf-8").splitlines())
             for pkg in PACKAGES for p in (ROOT / pkg).rglob("*.py")}
    assert len(sizes) > 100 and sizes["learn/monitor/alarms.py"] > 100      # the walk sees the packages' modules
    over = sorted(f"{name} ({n} lines)" for name, n in sizes.items() if n > MAX_LINES)
    assert not over, f"modules above {MAX_LINES} lines: {', '.join(over)}"
