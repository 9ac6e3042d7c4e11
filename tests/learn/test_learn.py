"""learn: features, sensitivities, classical methods, estimator, model directory, refusal rules."""

import json

import numpy as np
import pytest
import torch
from sklearn.base import clone
from sklearn.metrics import roc_auc_score

from learn.explanations.classical import cawley_adams, dlac, mdlac, sensitivity_updating
from learn.network.estimator import DamageClassifier, fit_calibration
from learn.network.evaluate import reliability, roc_auc
from learn.network.features import BeamSpec, curvatures, map_frf_to_grid, split_by_specimen
from learn.explanations.shapes import real_shapes
from learn.explanations.sensitivity import beam_sensitivity
from learn.network.model_dir import MODEL_FORMAT, TrainedModel, load_model, save_model
from physics.errors import BeamDamageError, FileFormatError
from physics.fem import beam_model
from physics.modal import undamped_modes
from physics.properties import beam_preset


def test_split_by_specimen_never_cuts_a_specimen():
    groups = np.repeat(np.arange(300), 3)       # three pairs per specimen
    parts = split_by_specimen(groups, (0.7, 0.15, 0.15), seed=3)
    sets = [set(groups[p]) for p in parts]
    assert not (sets[0] & sets[1]) and not (sets[0] & sets[2]) and not (sets[1] & sets[2])
    assert sum(len(p) for p in parts) == groups.size
    assert abs(len(sets[0]) - 210) <= 1 and abs(len(sets[2]) - 45) <= 1


def test_real_shapes_remove_complex_scaling_and_curvature_of_a_parabola():
    rng = np.random.default_rng(0)
    u = rng.normal(size=(4, 3))
    z = u * (0.3 - 2.1j)                                 # any complex scaling of a real mode
    got = real_shapes(z)
    ref = u / np.linalg.norm(u, axis=0) * np.sign(u[np.argmax(np.abs(u), axis=0), range(3)])
    np.testing.assert_allclose(got, ref, atol=1e-12)
    w = (np.arange(1, 5, dtype=float) ** 2)[:, None]     # w(x) = x^2 at nodes 2..5, clamp w = w' = 0 at x = 0
    np.testing.assert_allclose(curvatures(w)[:, 0], 2.0)


def test_log_grid_interpolation_is_exact_for_a_power_law():
    w = np.linspace(10.0, 6000.0, 5000)
    grid = np.geomspace(60.0, 4800.0, 40)
    H = (1.0 / w**2).astype(complex)
    np.testing.assert_allclose(map_frf_to_grid(H, w, grid), -2 * np.log10(grid), atol=1e-3)


def _independent_slit(x_over_L, loss, n_el=60, root=948.7):
    """Relative frequency shifts, complex eigen-data and hinge flexibility ``w r / ((1 - r) L)`` of a slit
    (one element losing the fraction ``loss`` of its rigidity) on an independent, finer FE mesh."""
    p = beam_preset("beam5")
    f = np.ones((2, n_el))
    f[1, min(int(x_over_L * n_el), n_el - 1)] -= loss
    m = beam_model(n_el, p.length_m, p.EI_Nm2, p.mass_per_length_kg_m, ei_factors=f,
                   root_spring=root * p.EI_Nm2 / p.length_m)
    w, phi = undamped_modes(m.M, m.K)
    idx = m.index([f"{1 + n_el // 4 * q}:y" for q in range(1, 5)])
    lam = -0.002 * w[:, :4] + 1j * w[:, :4]
    return w[1, :4] / w[0, :4] - 1, lam[None], phi[:, idx, :4][None].astype(complex), loss / ((1 - loss) * n_el)


@pytest.mark.parametrize("x", [0.12, 0.31, 0.47, 0.63])
def test_frequency_classical_methods_localise_a_slit_of_an_independent_fe_model(x):
    sens = beam_sensitivity("beam5", 948.7)
    df, lam, psi, s = _independent_slit(x, 0.4)
    for method in (dlac, cawley_adams, mdlac):
        out = method(df[None], sens, threshold=1e-4)
        assert out.damaged[0]
        assert abs(out.x_over_L[0] - x) < 0.05, (method.__name__, out.x_over_L[0], x)
    df, _, _, s = _independent_slit(x, 0.05)    # first order holds for a small loss: the size too
    out = dlac(df[None], sens, threshold=1e-5)
    assert out.size[0] == pytest.approx(s, rel=0.1)


def test_first_order_frequency_sensitivity_against_a_finer_mesh():
    sens = beam_sensitivity("beam5", 948.7)
    x = 12.5 / 40                                      # centre of a sensitivity element and of a fine element
    df, _, _, s = _independent_slit(x, 0.02, n_el=120)
    pred = sens.frequency[:, sens.element_of(x)] * s
    np.testing.assert_allclose(pred, df, rtol=0.08, atol=2e-6)


def test_sensitivity_updating_finds_the_element():
    sens = beam_sensitivity("beam5", 948.7)
    df, lam, psi, _ = _independent_slit(0.4, 0.3)
    u = real_shapes(psi[0])
    u0 = real_shapes(beam_pair_baseline_shapes())
    du = (u[1] * np.sign(np.sum(u[1] * u0, axis=0)) - u0).reshape(1, -1)
    out = sensitivity_updating(df[None], du, sens, threshold=0.0)
    assert abs(out.x_over_L[0] - 0.4) < 0.06


def beam_pair_baseline_shapes():
    _, _, psi, _ = _independent_slit(0.4, 0.0)
    return psi[0, 0]


def _synthetic(n, rng):
    """Pairs whose features are FE frequency shifts of a slit plus noise: the right answer is known."""
    sens = beam_sensitivity("beam5", 948.7)
    damaged = rng.random(n) < 0.6
    x = rng.uniform(0.0, 0.8, n)
    s = np.exp(rng.uniform(np.log(0.02), np.log(0.2), n))
    df = np.where(damaged[:, None], sens.frequency[:, sens.element_of(x)].T * s[:, None], 0.0)
    X = 100 * (df + 2e-4 * rng.standard_normal(df.shape))
    y = np.stack([damaged, np.where(damaged, x, np.nan), np.where(damaged, s, 0.0)], axis=1)
    return X, y


def test_classifier_learns_a_known_synthetic_problem():
    rng = np.random.default_rng(0)
    X, y = _synthetic(3000, rng)
    Xt, yt = _synthetic(600, rng)
    est = DamageClassifier(hidden=64, depth=2, epochs=30, n_bins=40, random_state=0).fit(X, y)
    d = est.predict_details(Xt)
    dam = yt[:, 0] > 0.5
    assert roc_auc_score(dam, d.probability_damaged) > 0.98
    assert np.median(np.abs(d.x_over_L[dam] - yt[dam, 1])) < 0.05
    assert np.median(np.abs(d.size[dam] / yt[dam, 2] - 1)) < 0.3
    np.testing.assert_allclose(d.element_probabilities.sum(axis=1), 1.0, atol=1e-5)
    assert 0.1 < est.logit_scale_ < 10
    # the intervals: nested, about the estimate, and covering held-out truths about as often as they say
    iv = d.intervals
    for q, est_q in (("x_over_L", d.x_over_L), ("size", d.size)):
        lo68, hi68, lo95, hi95 = iv[f"{q}_68"][:, 0], iv[f"{q}_68"][:, 1], iv[f"{q}_95"][:, 0], iv[f"{q}_95"][:, 1]
        assert np.all(lo95 <= lo68) and np.all(lo68 <= hi68) and np.all(hi68 <= hi95)
    assert np.all((iv["size_68"][:, 0] <= d.size) & (d.size <= iv["size_68"][:, 1]))
    called = dam & (d.probability_damaged >= d.threshold)
    for k, level in (("68", 0.68), ("95", 0.95)):
        for q, col in (("x_over_L", 1), ("size", 2)):
            inside = (iv[f"{q}_{k}"][called, 0] <= yt[called, col]) & (yt[called, col] <= iv[f"{q}_{k}"][called, 1])
            assert abs(np.mean(inside) - level) < 0.12, (q, k, np.mean(inside))
    assert len(est.location_sharpness_) == len(est.size_std_scale_) == len(est.thresholds_)
    for curve in est.location_sharpness_[0].values():   # fitted within its bracket, one point per group of spread
        assert np.all(np.abs(curve["ln_sharpness"]) <= np.log(20) + 1e-9)
        assert np.all(np.diff(curve["ln_spread"]) >= 0)
    # scikit-learn conventions: clone keeps params, drops fitted state
    c = clone(est)
    assert c.get_params() == est.get_params() and not hasattr(c, "model_")


def test_classifier_threads_apply_to_its_own_work_and_results_do_not_depend_on_them():
    rng = np.random.default_rng(2)
    X, y = _synthetic(300, rng)
    before = torch.get_num_threads()
    one = DamageClassifier(hidden=16, depth=1, epochs=2, n_bins=40, random_state=0).fit(X, y)
    two = DamageClassifier(hidden=16, depth=1, epochs=2, n_bins=40, random_state=0, n_threads=2).fit(X, y)
    assert torch.get_num_threads() == before and one.get_params()["n_threads"] == 1
    np.testing.assert_allclose(one.predict_proba(X), two.predict_proba(X), atol=1e-5)


def test_model_directory_round_trip_with_weights_only(tmp_path):
    rng = np.random.default_rng(1)
    X, y = _synthetic(400, rng)
    est = DamageClassifier(hidden=32, depth=1, epochs=2, n_bins=40, random_state=0).fit(X, y)
    beam = BeamSpec("beam5", 0.6095, ("2:y", "3:y", "4:y", "5:y"), "iirs")
    cfg = {"format": MODEL_FORMAT, "route": "modal", "beam": beam.to_dict(), "classical_thresholds": {"DLAC": 1e-3},
           "best_classical": "DLAC"}
    save_model(tmp_path, cfg, {"modal": est})
    with np.load(tmp_path / "weights-modal.npz", allow_pickle=False) as z:
        assert "norm.mean" in z.files and "net.trunk.0.weight" in z.files
    model = load_model(tmp_path)
    assert model.networks["modal"].model_ is None                      # it answers in NumPy (learn.network.forward)
    np.testing.assert_allclose(model.networks["modal"].predict_proba(X), est.predict_proba(X), atol=1e-6)
    np.testing.assert_allclose(model.networks["modal"].predict_details(X).location_distribution,
                               est.predict_details(X).location_distribution, atol=1e-6)
    # a directory written before: weights-modal.pt (torch.save), read with weights_only=True, answers alike
    arrays, _ = est.get_state()
    torch.save({k: torch.as_tensor(v) for k, v in arrays.items()}, tmp_path / "weights-modal.pt")
    (tmp_path / "weights-modal.npz").unlink()
    np.testing.assert_allclose(load_model(tmp_path).networks["modal"].predict_proba(X), est.predict_proba(X),
                               atol=1e-6)
    np.testing.assert_allclose(model.networks["modal"].predict_details(X).size_std,
                               est.predict_details(X).size_std, rtol=1e-5)
    assert model.networks["modal"].location_sharpness_ == est.location_sharpness_
    tensors, meta = est.get_state()                      # a model written before the key was "logit_scale"
    meta["temperature"] = meta.pop("logit_scale")
    assert DamageClassifier.from_state(tensors, meta).logit_scale_ == est.logit_scale_
    assert json.loads((tmp_path / "config.json").read_text())["beam"]["mass_model"] == "iirs"
    (tmp_path / "weights-modal.npz").write_text("not an archive")      # no advice to load it unsafely
    with pytest.raises(FileFormatError, match=r"weights-modal.npz: not a weights file readable as NumPy arrays "
                                              r"\(neither a zip archive nor an array file\)") as e:
        load_model(tmp_path)
    assert "pickle" not in str(e.value)


def test_refusal_names_what_differs():
    beam = BeamSpec("beam5", 0.6095, ("2:y", "3:y", "4:y", "5:y"), "iirs")
    model = TrainedModel(path="m", config={"beam": beam.to_dict()})
    model.check_beam(beam)
    with pytest.raises(BeamDamageError, match="mass model 'lumped'"):
        model.check_beam(BeamSpec("beam5", 0.6095, beam.dofs, "lumped"))
    with pytest.raises(BeamDamageError, match=r"DOF set \['2:y', '3:y', '4:y'\]"):
        model.check_beam(BeamSpec("beam5", 0.6095, beam.dofs[:3], "iirs"))
    with pytest.raises(BeamDamageError, match="beam 'beam8'"):
        model.check_beam(BeamSpec("beam8", 0.6095, beam.dofs, "iirs"))


def test_temperature_scaling_and_calibration_metrics():
    rng = np.random.default_rng(2)
    z = rng.normal(0, 2, 20000)
    y = rng.random(z.size) < 1 / (1 + np.exp(-z))
    t, b = fit_calibration(3 * z + 1.0, y)          # logits 3x overconfident and shifted
    assert t == pytest.approx(3.0, rel=0.08) and b == pytest.approx(-1.0 / 3, abs=0.05)
    p = 1 / (1 + np.exp(-z))
    assert reliability(p, y)[3] < 0.02
    assert reliability(1 / (1 + np.exp(-3 * z)), y)[3] > 0.05
    s = rng.normal(size=500)
    lab = rng.random(500) < 0.4
    assert roc_auc(s + lab, lab) == pytest.approx(roc_auc_score(lab, s + lab))


def test_size_spread_factors_give_each_level_its_coverage():
    """Transformed sizes scattered about the head's means with heavy tails (a std of 0.4 for 90 % of the pairs, 2.0
    for 10 %), a head claiming 0.1: each level's factor makes its interval hold its share, the 95 % factor larger
    than a Gaussian's (1.96 / 1.0 times the 68 % one)."""
    from learn.network.size import fit_size_scales, read_size_scales

    rng = np.random.default_rng(0)
    mu = rng.uniform(-3, 1, 20000)
    t = mu + np.where(rng.random(mu.size) < 0.9, 0.4, 2.0) * rng.standard_normal(mu.size)
    k = fit_size_scales(t, mu, np.full(mu.size, 0.1))
    for lv, level, z in (("68", 0.6827, 1.0), ("95", 0.95, 1.959964)):
        assert np.mean(np.abs(t - mu) <= z * k[lv] * 0.1) == pytest.approx(level, abs=0.002)
    assert 3.0 < k["68"] < 5.5 and k["95"] > 1.3 * k["68"]
    assert read_size_scales(2.0) == [{"68": 2.0, "95": 2.0}] == read_size_scales([{"68": 2, "95": 2}])


def test_a_signed_size_transform_keeps_the_sign_and_its_spread_covers():
    """asinh(size / 0.01): signed sizes round-trip, the one-sigma interval's half width is the reported std, and the
    std factor fitted on sizes scattered by 0.3 in the transformed space covers 68 % of them (both signs)."""
    from learn.network.size import SizeTransform, fit_size_scales

    tf = SizeTransform.parse("asinh:0.01")
    sizes = np.array([-0.2, -0.01, -1e-4, 0.0, 0.003, 0.15])
    np.testing.assert_allclose(tf.inverse(tf.forward(sizes)), sizes, atol=1e-15)
    t = tf.forward(0.05)
    assert tf.std(t, 0.1) == pytest.approx((tf.inverse(t + 0.1) - tf.inverse(t - 0.1)) / 2)
    assert SizeTransform.parse("log").forward(np.e) == pytest.approx(1.0)
    with pytest.raises(Exception, match="size_transform 'asinh:-1' unknown"):
        SizeTransform.parse("asinh:-1")
    rng = np.random.default_rng(1)
    mu = tf.forward(rng.uniform(-0.2, 0.2, 20000))
    t_true = mu + 0.3 * rng.standard_normal(mu.size)
    k = fit_size_scales(t_true, mu, np.full(mu.size, 0.1))["68"]
    lo, hi = tf.inverse(mu - k * 0.1), tf.inverse(mu + k * 0.1)
    truth = tf.inverse(t_true)
    assert np.mean((lo <= truth) & (truth <= hi)) == pytest.approx(0.6827, abs=0.005) and 2.5 < k < 3.5
    assert np.mean(truth < 0) == pytest.approx(0.5, abs=0.02)


def test_modal_features_ignore_a_global_stiffness_or_mass_scale():
    """A global EI (or mass) factor moves every frequency by one factor and no shift, shape or curvature: the
    features of an independent FE pair are the same for EI x 1.2."""
    from learn.network.features import modal_features

    p = beam_preset("beam5")
    feats = []
    for scale in (1.0, 1.2):
        f = np.ones((2, 40))
        f[1, 12] -= 0.4
        m = beam_model(40, p.length_m, scale * p.EI_Nm2, p.mass_per_length_kg_m, ei_factors=f,
                       root_spring=948.7 * scale * p.EI_Nm2 / p.length_m)
        w, phi = undamped_modes(m.M, m.K)
        idx = m.index(["11:y", "21:y", "31:y", "41:y"])
        lam = (-0.002 * w[:, :4] + 1j * w[:, :4])[None]
        feats.append(modal_features(lam, phi[:, idx, :4][None].astype(complex)))
    assert feats[0].shape == (1, 36)
    np.testing.assert_allclose(feats[1], feats[0], atol=1e-7)


def test_a_missing_mode_or_unpaired_shapes_put_a_pair_outside_the_training_data():
    """Mode 2 missed (modes 1, 3, 4, 5 taken as 1..4): a frequency ratio far from the nominal beam's; swapped
    shapes: MAC below 0.8. A clean pair of the nominal beam gives no reason."""
    from learn.pairs.measured import mode_checks, nominal_ratio_range

    sens = beam_sensitivity("beam5", 948.7)
    p = beam_preset("beam5")
    m = beam_model(40, p.length_m, p.EI_Nm2, p.mass_per_length_kg_m, root_spring=948.7 * p.EI_Nm2 / p.length_m)
    w, phi = undamped_modes(m.M, m.K)
    idx = m.index(["11:y", "21:y", "31:y", "41:y"])
    lam = -0.002 * w[:5] + 1j * w[:5]
    vec = phi[idx, :5].astype(complex)
    good = (np.stack([lam[:4], lam[:4]])[None], np.stack([vec[:, :4], vec[:, :4]])[None])
    assert mode_checks(*good, nominal_ratio_range(sens)) == [[]]
    miss = [0, 2, 3, 4]
    bad = (np.stack([lam[:4], lam[miss]])[None], np.stack([vec[:, :4], vec[:, miss]])[None])
    reasons = mode_checks(*bad, nominal_ratio_range(sens))[0]
    assert any("measured f2/f1" in r for r in reasons) and any("do not pair" in r for r in reasons)


def test_damage_classifier_follows_scikit_learn_conventions():
    """Parameters only in __init__ (scikit-learn's own checks), NotFittedError before fit, X of the wrong width
    refused naming both widths, score = accuracy of the verdict for the (n, 3) targets or their first column."""
    from sklearn.exceptions import NotFittedError
    from sklearn.utils import estimator_checks as ec

    # the checks of sklearn.utils.estimator_checks that apply: the others fit on 1-column class labels, which
    # fit refuses (y is (n, 3): damaged, x/L, size), or test sample weights and sparse input, which it does not take
    for check in (ec.check_no_attributes_set_in_init, ec.check_get_params_invariance, ec.check_set_params,
                  ec.check_parameters_default_constructible, ec.check_estimators_unfitted, ec.check_estimator_repr,
                  ec.check_estimator_cloneable, ec.check_do_not_raise_errors_in_init_or_set_params,
                  ec.check_estimator_tags_renamed, ec.check_valid_tag_types, ec.check_mixin_order):
        check("DamageClassifier", DamageClassifier())
    with pytest.raises(NotFittedError):
        DamageClassifier().predict(np.zeros((2, 4)))
    rng = np.random.default_rng(2)
    X, y = _synthetic(300, rng)
    est = DamageClassifier(hidden=16, depth=1, epochs=2, n_bins=40, random_state=0).fit(X, y)
    assert est.n_features_in_ == X.shape[1]
    with pytest.raises(BeamDamageError, match=f"X has {X.shape[1] - 1} features .* expecting {X.shape[1]}"):
        est.predict(X[:, :-1])
    acc = np.mean(est.predict(X) == (y[:, 0] > 0.5))
    assert est.score(X, y) == pytest.approx(acc) == est.score(X, y[:, 0])


def test_modes_are_paired_with_the_nominal_beam_by_frequency():
    """Modes 1, 2, 4 of a beam 5 % stiffer than nominal with shear (mode 4 8 % low) -> [0, 1, 3]; a spurious
    pole between modes 1 and 2 pairs with none; the order of the input is kept; a band cut -> [0, 1]."""
    from learn.pairs.measured import pair_modes_by_frequency

    nominal = beam_sensitivity("beam5", 948.7).frequencies_hz        # 19.9, 125, 349, 684 Hz
    f = nominal * np.sqrt(1.05) * np.array([1.0, 1.0, 1.0, 0.92])
    np.testing.assert_array_equal(pair_modes_by_frequency(f[[0, 1, 3]], nominal), [0, 1, 3])
    np.testing.assert_array_equal(pair_modes_by_frequency(f[[3, 0, 1]], nominal), [3, 0, 1])
    np.testing.assert_array_equal(pair_modes_by_frequency([f[0], 70.0, f[1], f[2]], nominal), [0, -1, 1, 2])
    np.testing.assert_array_equal(pair_modes_by_frequency(f[:2], nominal), [0, 1])
    np.testing.assert_array_equal(pair_modes_by_frequency([5.0, f[1]], nominal), [-1, 1])   # 5 Hz: 4 times below mode 1
    # 16 cantilever modes (beta_r L ~ (r - 1/2) pi), modes 5 and 11 missed and a spurious pole at 1.5 x mode 13
    nominal16 = ((np.arange(1, 17) - 0.5) * np.pi) ** 2
    found = np.r_[np.delete(nominal16, [4, 10]) * 1.02, 1.5 * nominal16[12]]
    expect = np.r_[np.delete(np.arange(16), [4, 10]), -1]
    np.testing.assert_array_equal(pair_modes_by_frequency(found, nominal16), expect)


@pytest.mark.parametrize("modes", [[0, 1, 2], [0, 1, 3], [0, 2, 3]])
def test_every_classical_method_localises_a_slit_on_three_of_the_four_modes(modes):
    """run_classical on the modes present (the sensitivities of those modes alone) places slits of an independent
    finer mesh in the right element, and a pair without change gives the smallest scores."""
    from learn.explanations.classical import run_classical

    sens = beam_sensitivity("beam5", 948.7)
    sub = sens.modes(modes)
    np.testing.assert_array_equal(sub.frequency, sens.frequency[modes])
    np.testing.assert_array_equal(sub.shape.reshape(4, 3, -1), sens.shape.reshape(4, 4, -1)[:, modes])
    for x in (0.31, 0.63):
        _, lam, psi, _ = _independent_slit(x, 0.4)
        outs, _ = run_classical(lam[..., modes], psi[..., modes], sub, {"freq": 1e-4, "upd": 0.0})
        for o in outs:
            assert o.damaged[0] and int(o.x_over_L[0] * 4) == int(x * 4), (o.name, x, o.x_over_L[0])


def test_support_head_learns_a_support_change_and_survives_the_model_directory(tmp_path):
    """A support change shifts every mode almost alike (a clamp spring 3x softer: -0.45, -0.44, -0.44, -0.43 %);
    intact pairs by noise only, slits by their FE shifts: the support head separates the support changes, the
    detect head does not call them damaged; a model without the fourth column has no support answer (NaN), before
    and after saving."""
    rng = np.random.default_rng(3)

    def data(n):
        X, y = _synthetic(n, rng)
        support = (y[:, 0] < 0.5) & (rng.random(n) < 0.5)
        shift = rng.choice([-1, 1], n) * rng.uniform(1.0, 3.0, n)           # percent, alike on the 4 modes
        X = X + np.where(support, shift, 0.0)[:, None] * np.array([1.0, 0.98, 0.98, 0.96])
        return X, np.column_stack([y, support])

    X, y = data(3000)
    Xt, yt = data(600)
    est = DamageClassifier(hidden=64, depth=2, epochs=80, n_bins=40, random_state=0).fit(X, y)
    d = est.predict_details(Xt)
    sup = yt[:, 3] > 0.5
    intact = yt[:, 0] < 0.5
    assert est.support_trained_ and roc_auc_score(sup[intact], d.probability_support_change[intact]) > 0.98
    assert np.mean(est.predict(Xt[sup])) < 0.1                                    # not false alarms
    old = DamageClassifier(hidden=16, depth=1, epochs=2, n_bins=40, random_state=0).fit(X, y[:, :3])
    assert not old.support_trained_ and np.isnan(old.predict_details(Xt).probability_support_change).all()
    beam = BeamSpec("beam5", 0.6095, ("2:y", "3:y", "4:y", "5:y"), "iirs")
    cfg = {"format": MODEL_FORMAT, "route": "modal", "beam": beam.to_dict(), "classical_thresholds": {"DLAC": 1e-3},
           "best_classical": "DLAC"}
    for e in (est, old):
        save_model(tmp_path, cfg, {"modal": e})
        back = load_model(tmp_path).networks["modal"].predict_details(Xt).probability_support_change
        np.testing.assert_allclose(back, e.predict_details(Xt).probability_support_change, atol=1e-6)


def test_a_baseline_damped_far_outside_the_training_is_named():
    """The model records the central 99 % of its training pairs' baseline damping ratios; a test damped beyond twice
    that range gets one warning naming the modes, and a test without damping (frequencies only) none."""
    from learn.pairs.inputs import damping_warning
    from learn.pairs.measured import ModalPair
    from learn.network.training import damping_ratio_range
    from physics.modal import eigenvalues_from_modal

    rng = np.random.default_rng(0)
    f_hz = np.array([20.0, 125.0, 350.0, 680.0])
    zeta = np.array([0.002, 0.0025, 0.003, 0.004]) * rng.uniform(0.7, 1.3, (2000, 1))
    lam = eigenvalues_from_modal(np.broadcast_to(f_hz, zeta.shape), zeta)
    trained = damping_ratio_range(np.stack([lam, lam], axis=1))
    np.testing.assert_allclose(np.array(trained)[:, 1] / np.array(trained)[:, 0], 1.3 / 0.7, rtol=0.02)
    beam = BeamSpec("beam5", 0.6095, ("2:y", "3:y", "4:y", "5:y"), "iirs")
    model = TrainedModel(path="m", config={"beam": beam.to_dict(), "damping_ratio_range": trained})

    def pair(z):
        lam = eigenvalues_from_modal(f_hz, np.asarray(z, float))
        return ModalPair(np.stack([lam, lam]), np.ones((2, 4, 4), complex), np.arange(4))

    assert damping_warning(model, [pair([0.002, 0.0025, 0.003, 0.004])]) is None
    text = damping_warning(model, [pair([0.002, 0.02, 0.003, 0.004])])
    assert "mode(s) 2 (2 %)" in text and "specimen.damping_ratios" in text
    assert damping_warning(model, [pair([0.0, 0.0, 0.0, 0.0])]) is None
    assert damping_warning(TrainedModel(path="m", config={"beam": beam.to_dict()}), [pair([0.1] * 4)]) is None


def _slits_of_beam5(n, rng, noise=5e-4):
    """Pairs of first-order slit shifts of beam 5 (the project's sensitivities; sizes 0.005-0.1) and 0.05 % noise
    per mode: the frequency features of a slit, labelled."""
    sens = beam_sensitivity("beam5", 948.7)
    damaged = rng.random(n) < 0.6
    x = rng.uniform(0.0, 0.8, n)
    s = np.exp(rng.uniform(np.log(0.005), np.log(0.1), n))
    df = np.where(damaged[:, None], sens.frequency[:, sens.element_of(x)].T * s[:, None], 0.0)
    X = 100 * (df + noise * rng.standard_normal(df.shape))
    return X, np.stack([damaged, np.where(damaged, x, np.nan), np.where(damaged, s, 0.0)], axis=1)


@pytest.fixture(scope="module")
def masked_net():
    """A frequency-input network trained with modes drawn missing (p = 0.15, at least 2 present)."""
    X, y = _slits_of_beam5(2500, np.random.default_rng(1))
    return DamageClassifier(hidden=64, depth=2, epochs=25, n_bins=40, random_state=0,
                            feature_modes=[0, 1, 2, 3]).fit(X, y), X


def _second_sim_shifts(x_over_L, width_m=0.006, loss=0.6):
    """Relative frequency shifts (percent) of modes 1-4 of beam 5 by a slit, from the independent simulator."""
    from experiments.second_sim.fem import Beam, Slit, assemble, modes

    L, EI, M = 0.6095, 26.9, 0.15792 / 1.219

    def f_hz(*slits):
        return modes(assemble(Beam(L, EI, M, root_k_theta_Nm_rad=948.7 * EI / L, slits=slits))).frequencies_hz[:4]

    return 100 * (f_hz(Slit(x_over_L * L, width_m, loss)) / f_hz() - 1)


def test_a_network_trained_with_modes_missing_places_a_slit_of_the_independent_simulator_with_any_mode_missing(
        masked_net):
    """A slit at x = 0.3 L (zone 2 of 4; hinge flexibility 0.015, drops of 0.3-1.2 %) computed by the independent
    simulator: the network calls it damaged in zone 2 on all four modes and with each mode missing (NaN)."""
    est, _ = masked_net
    df = _second_sim_shifts(0.3)
    rows = np.tile(df, (5, 1))
    rows[np.arange(1, 5), np.arange(4)] = np.nan
    d = est.predict_details(rows)
    np.testing.assert_array_equal(d.modes_present.sum(axis=1), [4, 3, 3, 3, 3])
    assert (d.probability_damaged >= d.threshold).all(), d.probability_damaged
    np.testing.assert_array_equal(d.element, 2)
    assert np.all(np.abs(d.x_over_L - 0.3) < 0.125), d.x_over_L                # within half a zone
    np.testing.assert_array_equal(d.threshold, np.asarray(est.thresholds_)[[0, 1, 1, 1, 1]])
    with pytest.raises(BeamDamageError, match="holds 1 of 4 modes; the network answers on 2 or more"):
        est.predict_details(np.array([[np.nan, np.nan, np.nan, -1.0]]))
    with pytest.raises(BeamDamageError, match="must be finite"):               # a network that needs every mode
        DamageClassifier(hidden=8, depth=1, epochs=0, n_bins=40).fit(*_slits_of_beam5(50, np.random.default_rng(0))) \
            .predict_details(rows)


def test_the_out_of_distribution_check_with_a_mode_missing_is_the_marginal_distance(masked_net):
    """With mode 3 missing the distance is the Mahalanobis distance of the other features against their own
    training statistics: that of a network fitted on those columns alone (same split), the same percentiles; an
    in-range slit of the independent simulator lies inside, a pair 20 times beyond the training's shifts outside."""
    est, X = masked_net
    keep = [0, 1, 3]
    alone = DamageClassifier(hidden=8, depth=1, epochs=0, n_bins=40, random_state=0).fit(
        X[:, keep], _slits_of_beam5(len(X), np.random.default_rng(1))[1])
    rows = np.stack([_second_sim_shifts(0.3), 20 * _second_sim_shifts(0.5)])
    masked = rows.copy()
    masked[:, 2] = np.nan
    dist, pct = est.training_percentile(masked)
    ref_dist, ref_pct = alone.training_percentile(rows[:, keep])
    np.testing.assert_allclose(dist, ref_dist, rtol=1e-9)
    np.testing.assert_allclose(pct, ref_pct)
    assert pct[0] < 99.9 and pct[1] == 100.0
    terms, Z = est.distance_terms(masked)
    assert np.isnan(terms[:, 2]).all() and np.isnan(Z[:, 2]).all()
    np.testing.assert_allclose(np.nansum(terms, axis=1), dist**2, rtol=1e-9)
    # the full pair: the distance of all four features, unchanged by the masks
    np.testing.assert_allclose(est.mahalanobis(rows), est._distances((rows - est.mean_) / est.scale_), rtol=1e-12)
