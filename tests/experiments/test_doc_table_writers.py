"""The docs tables of study_beams, bench_missing_modes --sweep, bench_debond_layered and bench_bolted_masses: what
--docs writes."""

import json

import numpy as np
import pytest

from experiments.benches import bench_bolted_masses, bench_debond_layered, bench_missing_modes, harness, study_beams
from experiments.second_sim.bolted import write_bolted_test
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
    """The page's block is the table ``study_beams --docs`` writes without ``--before``: no column of a run the page
    does not name."""
    text = (DOCS / "classifier.md").read_text()
    lines = block_text(text, "study-beams").splitlines()
    written = study_beams.docs_markdown([_row("a", "network", 0.9, 20, 0, 10), _row("a", "DLAC", 0.75, 20, 1, 10)],
                                        [{"beam": "a", "modes": [1, 2, 3]}]).splitlines()
    assert lines[:2] == written[:2] and "(before)" not in block_text(text, "study-beams")
    assert lines[-1].startswith("| all 8 | | | | ") and len(lines) == 2 + 8 + 1


def test_sweep_writes_its_own_block_and_leaves_the_others(monkeypatch, tmp_path):
    """--sweep alone (no held-out, simulator or catalogue rows) writes block missing-modes-sweep only."""
    swept = [{"p": p, "case": c, "auc": 0.9, "detection": 0.9, "false_alarms": fa, "element_accuracy": acc}
             for p in (0.0, 0.15) for c, acc, fa in (("none", 0.96, 0.024), ("mode 1", 0.43 + p, 0.0))]
    written = {}
    monkeypatch.setattr(bench_missing_modes, "sweep", lambda *a, **k: swept)
    monkeypatch.setattr(harness, "write_table", lambda page, name, md: written.__setitem__((page, name), md))
    assert bench_missing_modes.main(["--model", "M", "--sim-n", "0", "--sweep", "T", "--data", "D",
                                     "--out", str(tmp_path), "--docs"]) == 0
    assert list(written) == [("classifier.md", "missing-modes-sweep")]       # the page the bench's parser names
    assert written["classifier.md", "missing-modes-sweep"].splitlines()[2:] == [
        "| p | none missing | mode 1 missing |", "| --- | --- | --- |",
        "| 0 | 96% / 2.4% | 43% / 0.0% |", "| 0.15 | 96% / 2.4% | 58% / 0.0% |"]
    assert "missing-modes-sweep" in block_names((DOCS / "classifier.md").read_text())


@pytest.mark.slow  # 22 layered beams and one generator batch: 5-10 s
def test_debond_layered_reproduces_the_pages_table():
    c = bench_debond_layered.changes()
    assert np.all(np.abs(c["generator"] - c["sliding"]) <= 5e-4 * (1 + c["sliding"]))
    assert bench_debond_layered.markdown(c) == block_text((DOCS / "datasets.md").read_text(), "debond-layered")


TRUTH = {"kGA_N": 7942725.5, "modulus_pa": 200e9, "poisson_ratio": 0.29}


def test_bolted_cells_name_masses_shear_against_the_truth_and_the_noise_blocks():
    masses = {"effects": ["added_mass", "added_mass#2"], "indistinguishable_from": [],
              "parameters": {"EI_Nm2": 45.0, "added_mass.mass_kg": 0.0026, "added_mass.x_m": 0.3321,
                             "added_mass#2.mass_kg": 0.00384, "added_mass#2.x_m": 0.2304}, "parameter_std": {}}
    assert bench_bolted_masses.named_cell(masses, TRUTH) == \
        "`added_mass`, `added_mass#2` (2.6 g at 0.332 m; 3.8 g at 0.230 m)"
    shear = {"effects": ["shear_deformation"], "indistinguishable_from": ["added_mass#7"],
             "parameters": {"shear_deformation.kGA_N": 9.2009e6, "shear_deformation.G_pa": 8.98e10},
             "parameter_std": {"shear_deformation.kGA_N": 1.48e6, "shear_deformation.G_pa": 1.45e10}}
    # truth G = E / (2 (1 + nu)) = 200 / 2.58 GPa = 77.5 GPa
    assert bench_bolted_masses.named_cell(shear, TRUTH) == (
        "`shear_deformation` (kGA 9.2e6 +- 1.5e6 N, G 90 +- 14 GPa; truth 7.94e6 N, 77.5 GPa), not told from "
        "`added_mass#7`")
    assert bench_bolted_masses.named_cell({**masses, "effects": [], "parameters": {}}, TRUTH) == "none"
    blocks = {"frequencies": {"dof": 0, "chi2_per_dof": float("nan")}, "mode shapes": {"dof": 12, "chi2_per_dof": 6.31}}
    assert bench_bolted_masses.noise_cell({"noise_consistent": False, "chi2_per_dof": 6.0, "blocks": blocks}) == \
        "frequencies fitted (no dof left), mode shapes chi2/dof 6.3"
    assert bench_bolted_masses.noise_cell({"noise_consistent": True, "chi2_per_dof": 0.4422, "blocks": blocks}) == \
        "consistent (chi2/dof 0.44)"


@pytest.mark.slow  # one discrepancy run with three rounds: 15-35 s
def test_bolted_row_with_the_masses_in_the_beam_file(tmp_path):
    """With the six masses in the beam file the model is consistent with the noise, shear deformation is named
    within 25 % of the simulator's kGA, and the gap falls from 0.33 % (as given) to the 0.03 % noise."""
    out = write_bolted_test(tmp_path, seed=0)
    r = bench_bolted_masses.row(out / "bolted.toml", out / "baseline_modal.json",
                                json.loads((out / "truth.json").read_text()))
    assert r[0].startswith("`bolted.toml`") and r[1].startswith("`shear_deformation` (kGA ")
    kga = float(r[1].split("kGA ")[1].split(" ")[0])
    assert kga == pytest.approx(7.94e6, rel=0.25)
    assert r[2] == "0.332 %" and float(r[4].split()[0]) < 0.03 and r[5] == "consistent (chi2/dof 0.44)"
    block = block_text((DOCS / "discrepancy.md").read_text(), "bolted-masses").splitlines()
    assert len(block) == 4 and block[0] == bench_bolted_masses.markdown([r]).splitlines()[0]   # the page's header


def test_study_beams_refuses_an_unreadable_before_file_in_one_line(tmp_path, capsys):
    bad = tmp_path / "beams.json"
    bad.write_text('{"config": {}}')
    assert study_beams.main(["--out", str(tmp_path / "o"), "--before", str(bad), "--docs"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "--before" in err and "beams.json of a study_beams run" in err
    assert not (tmp_path / "o").exists()                          # nothing run, nothing written
