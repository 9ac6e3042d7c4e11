"""The docs tables of study_beams, bench_missing_modes --sweep and bench_debond_layered: what --docs writes."""

import numpy as np
import pytest

from experiments.benches import bench_debond_layered, bench_missing_modes, study_beams
from experiments.studies.doc_tables import DOCS, block_names, block_text


def _row(beam, method, zone, damaged, fa, intact, best="DLAC", bc="clamped-free", sensors=3, folded=False):
    return {"beam": beam, "bc": bc, "sensors": sensors, "method": method, "zone_accuracy": zone,
            "damaged_pairs": damaged, "detection": zone, "intact_pairs": intact, "false_alarms": fa,
            "false_alarm_pct": 100 * fa / intact,
            "median_dx_over_L": 0.00224, "folded": folded, "median_size_error": 0.11, "size_one_sigma_cover": 0.79,
            "best_classical": best}


def test_study_beams_docs_table_is_the_pages_layout_with_pooled_row_and_before():
    rows = [_row("a", "network", 0.9, 20, 0, 10, folded=True, bc="pinned-pinned", sensors=1),
            _row("a", "DLAC", 0.75, 20, 1, 10), _row("a", "verdict", 0.9, 20, 0, 10),
            *(_row("b", m, z, 10, fa, 5, best="Cawley-Adams") for m, z, fa in (("network", 0.5, 0),
                                                                                ("Cawley-Adams", 0.2, 0),
                                                                                ("DLAC", 0.1, 2)))]
    infos = [{"beam": "a", "modes": [1, 2, 3, 4, 5]}, {"beam": "b", "modes": [1, 2, 3, 4]}]
    before = [_row("a", "network", 0.8, 20, 0, 10), _row("b", "network", 0.2, 10, 0, 5),
              _row("c", "network", 0.0, 50, 0, 5)]                      # a beam not in this run: left out
    md = study_beams.docs_markdown(rows, infos, before).splitlines()
    assert md[0] == ("| beam | support | sensors | modes | network zone acc. (before) | best classical: zone acc. | "
                     "network median abs(dx)/L | false alarms (network) | size err. | size 1-sigma |")
    assert md[1] == "|---|---|---|---|---|---|---|---|---|---|"
    assert md[2] == "| a | pinned-pinned | 1 | 5 | 90% of 20 (80%) | DLAC 75% | 0.0022 (folded) | 0 of 10 | 11% | 79% |"
    assert md[3] == "| b | clamped-free | 3 | 4 | 50% of 10 (20%) | Cawley-Adams 20% | 0.0022 | 0 of 5 | 11% | 79% |"
    # pooled over damaged pairs: (18 + 5) / 30 (before (16 + 2) / 30); best classical (15 + 2) / 30, false alarms 1 + 0
    assert md[4] == "| all 2 | | | | 77% of 30 (60%) | 57% | | 0 of 15 (classical 1) | | |"
    plain = study_beams.docs_markdown(rows, infos)
    assert "(before)" not in plain and "90% of 20 |" in plain and "77% of 30 |" in plain


def test_the_pages_study_beams_table_has_the_layout_docs_markdown_writes():
    text = (DOCS / "classifier.md").read_text()
    lines = block_text(text, "study-beams").splitlines()
    assert lines[0].startswith("| beam | support | sensors | modes | network zone acc. (before) |")
    assert lines[-1].startswith("| all 8 | | | | ") and len(lines) == 2 + 8 + 1


def test_sweep_writes_its_own_block_and_leaves_the_others(monkeypatch, tmp_path):
    """--sweep alone (no held-out, simulator or catalogue rows) writes block missing-modes-sweep only."""
    swept = [{"p": p, "case": c, "auc": 0.9, "detection": 0.9, "false_alarms": fa, "element_accuracy": acc}
             for p in (0.0, 0.15) for c, acc, fa in (("none", 0.96, 0.024), ("mode 1", 0.43 + p, 0.0))]
    written = {}
    monkeypatch.setattr(bench_missing_modes, "sweep", lambda *a, **k: swept)
    monkeypatch.setattr(bench_missing_modes, "write_table", lambda page, name, md: written.__setitem__(name, md))
    assert bench_missing_modes.main(["--model", "M", "--sim-n", "0", "--sweep", "T", "--data", "D",
                                     "--out", str(tmp_path), "--docs"]) == 0
    assert list(written) == ["missing-modes-sweep"]
    assert written["missing-modes-sweep"].splitlines()[2:] == [
        "| p | none missing | mode 1 missing |", "| --- | --- | --- |",
        "| 0 | 96% / 2.4% | 43% / 0.0% |", "| 0.15 | 96% / 2.4% | 58% / 0.0% |"]
    assert "missing-modes-sweep" in block_names((DOCS / "classifier.md").read_text())


@pytest.mark.slow  # 22 layered beams and one generator batch: 5-10 s
def test_debond_layered_reproduces_the_pages_table():
    c = bench_debond_layered.changes()
    assert np.all(np.abs(c["generator"] - c["sliding"]) <= 5e-4 * (1 + c["sliding"]))
    assert bench_debond_layered.markdown(c) == block_text((DOCS / "datasets.md").read_text(), "debond-layered")
