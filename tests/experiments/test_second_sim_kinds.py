"""second_sim's layered sandwich beam against its own FE beam, the kind pairs it writes, and bench_debond's table."""

import json
import math

import numpy as np
import pytest

from experiments.benches.bench_debond import confusion, markdown
from experiments.second_sim.__main__ import main
from experiments.second_sim.fem import Beam, assemble, modes
from experiments.second_sim.kind_pairs import CORE_MODULUS_PA, FACE_THICKNESS_M, simulate_kind_pairs
from experiments.second_sim.layered import Sandwich, composite_ei, debond_ei, face_modulus_for, layered_assembled, \
    layered_matrices
from experiments.second_sim.pairs import LENGTH_M, MASS_PER_LENGTH_KG_M, THICKNESS_M, WIDTH_M


@pytest.mark.parametrize("k_theta", [math.inf, 2000.0, 200.0])
def test_bonded_layered_beam_on_a_root_spring_is_the_composite_fe_beam(k_theta):
    """The layered model without debonds (face tied to the core everywhere) on a root spring: the fem beam of the
    composite rigidity on that spring, mode by mode to 1e-6."""
    EI = 22.674
    ef = face_modulus_for(EI, WIDTH_M, THICKNESS_M, FACE_THICKNESS_M, CORE_MODULUS_PA)
    sec = Sandwich(WIDTH_M, THICKNESS_M, FACE_THICKNESS_M, ef, CORE_MODULUS_PA)
    assert composite_ei(sec) == pytest.approx(EI, rel=1e-9)
    asm, _ = layered_assembled(LENGTH_M, sec, MASS_PER_LENGTH_KG_M, (), 120, True, k_theta)
    fe = Beam(LENGTH_M, EI, MASS_PER_LENGTH_KG_M, root_k_theta_Nm_rad=k_theta, n_elements=120)
    np.testing.assert_allclose(modes(asm).frequencies_hz[:4], modes(assemble(fe)).frequencies_hz[:4], rtol=1e-6)
    assert asm.translation_dofs([LENGTH_M / 4, LENGTH_M]).size == 2


def test_kind_pairs_hold_their_change(tmp_path):
    """A debond lowers every frequency, more than the tied one; intact pairs repeat; the CLI writes the files."""
    rec = simulate_kind_pairs(1, 3, ("debond", "intact"))
    tied = simulate_kind_pairs(1, 3, ("debond",), tied_tips=True)
    d, i, t = rec[0].truth, rec[1].truth, tied[0].truth
    assert d["change"] == "debond" and d["ei_loss"] == pytest.approx(0.978, abs=2e-3)
    drop = np.array(d["current_frequencies_hz"]) / np.array(d["baseline_frequencies_hz"]) - 1
    drop_tied = np.array(t["current_frequencies_hz"]) / np.array(t["baseline_frequencies_hz"]) - 1
    assert np.all(drop < 0) and np.all(drop <= drop_tied + 1e-9) and drop.min() < -0.05
    assert i["baseline_frequencies_hz"] == i["current_frequencies_hz"] and not i["damaged"]
    assert main(["kinds", "--n", "1", "--changes", "debond", "mass", "--out", str(tmp_path)]) == 0
    truth = json.loads((tmp_path / "truth.json").read_text())["pairs"]
    assert [p["change"] for p in truth] == ["debond", "mass"]
    assert all((tmp_path / p[k]).exists() for p in truth for k in ("baseline", "current"))
    assert (tmp_path / "pair-000_current.uff").stat().st_size > 0
    assert main(["kinds", "--changes", "crack", "--out", str(tmp_path)]) == 2


def test_confusion_counts_the_most_likely_explanation_per_change():
    def verdict(best, fits=True, apart=True, damaged=True):
        return {"hypotheses": [{"name": best, "fits": fits}, {"name": "intact", "fits": True}],
                "hypotheses_summary": "x" if apart else "y cannot be told apart z", "network": {"damaged": damaged}}

    truth = [{"change": "debond", "tied_tips": False}, {"change": "debond", "tied_tips": False},
             {"change": "debond", "tied_tips": True}, {"change": "slit"}]
    verdicts = [verdict("debond"), verdict("slit", apart=False), verdict("slit", fits=False, damaged=False),
                verdict("slit")]
    rows, names = confusion(truth, verdicts)
    by = {r["change"]: r for r in rows}
    assert names == ["debond", "intact", "slit"]
    assert by["debond (sliding)"]["debond"] == 0.5 and by["debond (sliding)"]["slit"] == 0.5
    assert by["debond (sliding)"]["told apart"] == 0.5 and by["debond (tied tips)"]["slit"] == 1.0
    assert by["debond (tied tips)"]["fits"] == 0.0 and by["debond (sliding)"]["fits"] == 1.0
    assert by["debond (tied tips)"]["network detected"] == 0.0 and by["slit"]["slit"] == 1.0
    assert "| debond (sliding) | 2 | 100 % | 50 % | 0 % | 50 % | 100 % | 50 % |" in markdown(rows, names)


@pytest.mark.parametrize("tied", [True, False])
def test_tip_deflection_of_a_debonded_cantilever_is_the_closed_form(tied):
    """A tip load P on the clamped layered beam debonded over [a, b]. Sliding face: the moment bends the debonded
    length with EI_d, ``P (L^3 / 3 EI + (1/EI_d - 1/EI) int_a^b (L - x)^2 dx)``. Tips tied: the face's constant
    force carries the mean moment over the debond with the composite EI, only its variation bends with EI_d,
    ``P (L^3 / 3 EI + (1/EI_d - 1/EI) l^3 / 12)`` (complementary energy).
    Both to 1e-7 (measured: 6e-9, the round-off of condensing the axial DOFs)."""
    EI = 22.674
    ef = face_modulus_for(EI, WIDTH_M, THICKNESS_M, FACE_THICKNESS_M, CORE_MODULUS_PA)
    sec = Sandwich(WIDTH_M, THICKNESS_M, FACE_THICKNESS_M, ef, CORE_MODULUS_PA)
    L, n = LENGTH_M, 120
    a, b = 30 * L / n, 42 * L / n
    _, K, _ = layered_matrices(L, sec, MASS_PER_LENGTH_KG_M, [(a, b)], n, tied)
    load = np.zeros(K.shape[0])
    load[-2] = 1.0                                            # the tip's deflection DOF
    tip = np.linalg.solve(K, load)[-2]
    extra = (1 / debond_ei(sec) - 1 / composite_ei(sec))
    expected = L**3 / (3 * EI) + extra * ((b - a) ** 3 / 12 if tied else ((L - a) ** 3 - (L - b) ** 3) / 3)
    assert tip == pytest.approx(expected, rel=1e-7)
