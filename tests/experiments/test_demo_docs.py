"""The demo's numbers in README.md and docs/demo.md are the ones the demo computes (``beam-damage demo --docs``)."""

import argparse
import json

import pytest

from experiments.studies import demo
from experiments.studies.doc_tables import DOCS, block_text
from physics.io import to_jsonable


def test_doc_blocks_say_what_the_run_computed():
    """The numbers block is built from the run's result (two classical methods, the best by element accuracy)."""
    rows = [{"method": "network", "roc_auc": 0.9876, "element_accuracy": 0.969, "median_location_error_mm": 2.24,
             "median_size_error": 0.131, "false_alarm_rate": 0.0115},
            {"method": "DLAC", "roc_auc": 0.859, "element_accuracy": 0.9, "false_alarm_rate": 0.28},
            {"method": "Cawley-Adams", "roc_auc": 0.95, "element_accuracy": 0.8, "false_alarm_rate": 0.1}]
    result = {"discrepancy": {"effects": ["shear_deformation"], "gap_before": {"max_abs_frequency_error_pct": 8.07},
                              "gap_after": {"max_abs_frequency_error_pct": 0.27}},
              "classify": {"damaged": True, "location_x_m": 0.0791, "location_element": 1, "verdict_from": "network",
                           "hypotheses": [{"name": "mass_change", "probability": 0.43},
                                          {"name": "slit", "probability": 0.43}]},
              "evaluate": rows, "validate_passed_count": 38, "checks": 38, "test_pairs": 5000, "seconds": 95.0,
              "machine": "2 cores", "step_seconds": {"identify": 0.6, "discrepancy": 2.9, "dataset": 7.7,
                                                     "train": 47.0, "evaluate": 1.2}}
    blocks = demo.doc_blocks(result)
    numbers = blocks[("demo.md", "demo-numbers")]
    assert numbers.startswith("38 of 38 thesis checks pass; shear deformation named, largest frequency error "
                              "8.07 % -> 0.27 %; on the 5000 held-out specimens")
    assert "ROC AUC 0.988, element accuracy 96.9 %" in numbers and "1.1 % false alarms" in numbers
    assert "(DLAC, the best classical method: ROC AUC 0.859, element accuracy 90.0 %, 28.0 % false alarms)" in numbers
    assert numbers.endswith("by the network; its explanations: a mass change 0.43, a slit 0.43.")
    assert "training 47 s" in blocks[("demo.md", "demo-timings")]
    assert blocks[(str(DOCS.parent / "README.md"), "demo-numbers")] == numbers
    # the run's demo.json (its --json) gives the same blocks
    assert demo.doc_blocks(json.loads(json.dumps(to_jsonable(result)))) == blocks


def test_demo_page_states_the_dataset_sizes_the_demo_uses():
    (n_train, n_test, _), (n_quick, _, epochs_quick) = demo.SIZES["full"], demo.SIZES["quick"]
    text = (DOCS / "demo.md").read_text(encoding="utf-8")
    assert f"a {n_train:_}-specimen `training` dataset and a {n_test:_}-specimen test set".replace("_", " ") in text
    assert f"(a {n_quick:_}-specimen dataset, {epochs_quick} epochs)".replace("_", " ") in text


@pytest.mark.slow
def test_the_docs_hold_the_numbers_the_demo_computes(tmp_path):
    """A full demo run (about two minutes on 2 cores): its numbers block equals the one in both pages."""
    args = argparse.Namespace(out=str(tmp_path / "demo"), quick=False, force=True, samples=None, workers=2,
                              json=True, docs=False)
    numbers = demo.doc_blocks(demo.run(args))[("demo.md", "demo-numbers")]
    saved = json.loads((tmp_path / "demo" / "demo.json").read_text(encoding="utf-8"))
    assert demo.doc_blocks(saved)[("demo.md", "demo-numbers")] == numbers
    for page in (DOCS / "demo.md", DOCS.parent / "README.md"):
        assert block_text(page.read_text(encoding="utf-8"), "demo-numbers") == numbers, page
