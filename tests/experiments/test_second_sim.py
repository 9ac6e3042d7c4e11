"""The independent simulator ``experiments.second_sim`` against closed forms, an exact ODE solution,
first-order sensitivity, pyuff read-back and the project's FRF reader (the system under test)."""

import ast
import json
import math
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg
import scipy.optimize

from experiments.second_sim import effects, pairs
from experiments.second_sim.fem import Beam, Dashpot, PointMass, Slit, assemble, modes
from experiments.second_sim.response import Damping, complex_modes, rayleigh_for, receptance
from experiments.second_sim.writers import write_uff

L, EI, M = pairs.LENGTH_M, pairs.EI_NM2, pairs.MASS_PER_LENGTH_KG_M
PACKAGE = Path(pairs.__file__).parent


def _fe_hz(beam, n=4):
    return modes(assemble(beam)).frequencies_hz[:n]


def _roots(g, lam_max=12.0, n=4):
    """First ``n`` roots of ``g`` on (0.5, lam_max] by a scan for sign changes and brentq."""
    x = np.linspace(0.5, lam_max, 600)
    v = np.array([g(t) for t in x])
    idx = np.nonzero(np.sign(v[:-1]) != np.sign(v[1:]))[0]
    return np.array([scipy.optimize.brentq(g, x[i], x[i + 1], xtol=1e-14) for i in idx[:n]])


def _hz(lam):
    """Frequency (Hz) of a nondimensional ``lambda = beta L`` of the nominal Euler-Bernoulli beam."""
    return lam ** 2 / (2 * math.pi * L ** 2) * math.sqrt(EI / M)


def test_euler_bernoulli_cantilever_matches_closed_form():
    lam = np.array([1.8751040687, 4.6940911330, 7.8547574382, 10.9955407349])
    np.testing.assert_allclose(_fe_hz(Beam(L, EI, M)), _hz(lam), rtol=1e-6)


@pytest.mark.parametrize("K, Ky", [(13.0, math.inf), (40.0, 2000.0)])
def test_root_springs_match_the_frequency_equation(K, Ky):
    """Rotational spring ``K = k L / EI`` (and translational ``Ky = k_y L^3 / EI``) at the root."""
    # W = a1 cos + a2 sin + a3 cosh + a4 sinh (argument beta x): EI W''(0) = k W'(0),
    # EI W'''(0) = -k_y W(0) (or W(0) = 0), W''(L) = W'''(L) = 0

    def det(t):
        c, s, ch, sh = math.cos(t), math.sin(t), math.cosh(t), math.sinh(t)
        row0 = [1, 0, 1, 0] if math.isinf(Ky) else [Ky / t ** 3, -1, Ky / t ** 3, 1]
        return np.linalg.det(np.array([row0, [-1, -K / t, 1, -K / t], [-c, -s, ch, sh], [s, -c, sh, ch]]))

    f_exact = _hz(_roots(det))
    f_fe = _fe_hz(Beam(L, EI, M, root_k_theta_Nm_rad=K * EI / L, root_k_y_N_m=Ky * EI / L ** 3))
    np.testing.assert_allclose(f_fe, f_exact, rtol=1e-6)
    assert f_fe[0] < 0.96 * _hz(1.8751040687)  # the springs lower mode 1 by 4.8 and 12.6 %


def test_tip_mass_matches_frequency_equation():
    mu = 0.1  # tip mass / (m L)

    def g(t):
        return 1 + math.cos(t) * math.cosh(t) + mu * t * (math.cos(t) * math.sinh(t) - math.sin(t) * math.cosh(t))

    f_fe = _fe_hz(Beam(L, EI, M, masses=(PointMass(L, mu * M * L),)))
    np.testing.assert_allclose(f_fe, _hz(_roots(g)), rtol=1e-6)


def _timoshenko_exact_hz(kga, rho_i, n=4):
    """Clamped-free Timoshenko beam: ``det`` of the free block of the transfer matrix ``expm(A L)`` of
    ``[w, theta, M, V]``."""

    def det(w):
        A = np.array([[0, 1, 0, 1 / kga], [0, 0, 1 / EI, 0], [0, -rho_i * w ** 2, 0, -1], [-M * w ** 2, 0, 0, 0]])
        T = scipy.linalg.expm(A * L)
        return np.linalg.det(T[2:, 2:])

    grid = 2 * math.pi * np.linspace(5, 900, 3000)
    v = np.array([det(w) for w in grid])
    idx = np.nonzero(np.sign(v[:-1]) != np.sign(v[1:]))[0][:n]
    return np.array([scipy.optimize.brentq(det, grid[i], grid[i + 1], xtol=1e-10) for i in idx]) / (2 * math.pi)


def test_timoshenko_matches_exact_solution():
    kga, rho_i = 1000 * EI / L ** 2, 20 * pairs.RHO_I_KG_M
    beam = Beam(L, EI, M, kGA_N=kga, rho_I_kg_m=rho_i)
    f_exact = _timoshenko_exact_hz(kga, rho_i)
    err = _fe_hz(beam) / f_exact - 1
    np.testing.assert_allclose(err, 0, atol=1e-4)
    assert _fe_hz(beam)[3] < 0.95 * _fe_hz(Beam(L, EI, M))[3]  # shear is visible in mode 4
    # piecewise-constant shear strain: the error falls as h^2
    err2 = _fe_hz(replace(beam, n_elements=224)) / f_exact - 1
    np.testing.assert_allclose(err2[1:] / err[1:], 0.25, atol=0.01)


def test_timoshenko_set_kga_gives_the_mode4_drop():
    kga = pairs.nominal_kGA_N()
    f_t = _fe_hz(Beam(L, EI, M, kGA_N=kga, rho_I_kg_m=pairs.RHO_I_KG_M))
    assert f_t[3] / _fe_hz(Beam(L, EI, M))[3] == pytest.approx(0.92, abs=1e-5)


def _eb_curvature(x, lam):
    """Curvature of the mass-normalised Euler-Bernoulli cantilever mode (1/m^2 / sqrt(kg))."""
    b = lam / L
    sig = (math.cos(lam) + math.cosh(lam)) / (math.sin(lam) + math.sinh(lam))
    return b ** 2 / math.sqrt(M * L) * (math.cosh(b * x) + math.cos(b * x) - sig * (math.sinh(b * x) + math.sin(b * x)))


@pytest.mark.parametrize("x_over_L", [0.2, 0.55])
def test_small_slit_matches_first_order_sensitivity(x_over_L):
    lam = np.array([1.8751040687, 4.6940911330, 7.8547574382, 10.9955407349])
    s = Slit(x_over_L * L, 0.004, 0.01)
    beam = Beam(L, EI, M)
    df = _fe_hz(replace(beam, slits=(s,))) / _fe_hz(beam) - 1
    omega = 2 * math.pi * _hz(lam)
    pred = -s.stiffness_loss_Nm3(EI) * np.array([_eb_curvature(s.x_m, t) for t in lam]) ** 2 / (2 * omega ** 2)
    np.testing.assert_allclose(df, pred, rtol=0.05, atol=0.05 * np.abs(pred).max())
    assert np.abs(pred).max() > 1e-5


def test_narrow_deep_slit_acts_as_a_hinge_of_its_flexibility():
    """A narrow slit at any depth shifts omega^2 by ``-EI L theta kappa^2`` (theta its hinge flexibility)."""
    lam = np.array([1.8751040687, 4.6940911330, 7.8547574382, 10.9955407349])
    beam = Beam(L, EI, M)
    for r in (0.3, 0.6, 0.85):
        s = Slit(0.3 * L, 0.001, r)
        df = _fe_hz(replace(beam, slits=(s,))) / _fe_hz(beam) - 1
        omega = 2 * math.pi * _hz(lam)
        kappa = np.array([_eb_curvature(s.x_m, t) for t in lam])
        pred = -EI * L * s.hinge_flexibility(L) * kappa ** 2 / (2 * omega ** 2)
        np.testing.assert_allclose(df, pred, rtol=0.08, atol=0.05 * np.abs(pred).max())
        first_order_in_loss = -s.stiffness_loss_Nm3(EI) * kappa ** 2 / (2 * omega ** 2)
        assert np.abs(first_order_in_loss / df - 1).max() > (0.5 * r if r > 0.5 else 0.15)   # the loss alone is not


def test_slit_straddling_elements_equals_the_sum_of_its_parts():
    """A slit over an element boundary acts on both elements exactly as two adjacent slits."""
    h = L / 112
    x0 = 30 * h
    one = _fe_hz(Beam(L, EI, M, slits=(Slit(x0, 0.004, 0.5),)))
    two = _fe_hz(Beam(L, EI, M, slits=(Slit(x0 - 0.001, 0.002, 0.5), Slit(x0 + 0.001, 0.002, 0.5))))
    np.testing.assert_allclose(one, two, rtol=1e-10)
    assert one[0] < _fe_hz(Beam(L, EI, M))[0] * (1 - 1e-4)


def _direct_receptance(asm, md, damping, f_hz, resp, ref):
    d = damping.diagonal(md.omega_rad_s)
    C = asm.M @ md.phi @ np.diag(d) @ md.phi.T @ asm.M + asm.C
    out = []
    for f in f_hz:
        w = 2 * math.pi * f
        e = np.zeros(asm.K.shape[0])
        e[ref] = 1.0
        out.append(np.linalg.solve(asm.K - w * w * asm.M + 1j * w * C, e)[resp])
    return np.array(out).T


@pytest.mark.parametrize("damping", [Damping("modal", (0.004, 0.01, 0.02)), rayleigh_for(0.005, 0.01, 130, 4500)])
@pytest.mark.parametrize("c_Ns_m", [0.0, 4.0])
def test_receptance_matches_direct_solve(damping, c_Ns_m):
    beam = Beam(L, EI, M, kGA_N=3e4, root_k_theta_Nm_rad=1e4, dashpots=(Dashpot(0.3, c_Ns_m),) if c_Ns_m else ())
    asm = assemble(beam)
    md = modes(asm)
    resp = asm.translation_dofs(pairs.NODE_X_M[1:])
    f = np.array([3.0, 21.3, 130.7, 420.0, 799.0])
    H = receptance(asm, md, damping, f, resp, resp[0])
    np.testing.assert_allclose(H, _direct_receptance(asm, md, damping, f, resp, resp[0]), rtol=1e-5)


def test_complex_modes_satisfy_the_quadratic_eigenproblem():
    beam = Beam(L, EI, M, dashpots=(Dashpot(L / 4, 6.0), Dashpot(0.9 * L, 2.0)))
    asm = assemble(beam)
    md = modes(asm)
    damping = Damping("modal", (0.005,))
    lam, x = complex_modes(asm, md, damping, np.arange(asm.K.shape[0]))  # full shapes
    C = asm.M @ md.phi @ np.diag(damping.diagonal(md.omega_rad_s)) @ md.phi.T @ asm.M + asm.C
    for j, la in enumerate(lam):  # backward error at round-off level (a 1e-7 error in lambda would fail)
        res = (la ** 2 * asm.M + la * C + asm.K) @ x[:, j]
        assert np.linalg.norm(res) < 1e-15 * np.linalg.norm(asm.K) * np.linalg.norm(x[:, j])
    zeta = -lam.real / np.abs(lam)
    assert np.all(zeta > 0.0055)  # the dashpots add damping to every mode
    assert np.all(np.diff(lam.imag) > 0)


@pytest.fixture(scope="module")
def cases():
    return effects.effect_cases(5)


def test_local_damping_case_adds_the_target_damping_ratio(cases):
    case = cases[-1]
    assert case.truth["effect"] == "local_damping" and case.truth["value"] == 0.02
    asm = assemble(case.beam)
    md = modes(asm)
    dofs = asm.translation_dofs(pairs.NODE_X_M[1:])
    lam, psi = complex_modes(asm, md, case.damping, dofs)
    lam0, _ = complex_modes(assemble(replace(case.beam, dashpots=())), md, case.damping, dofs)
    added = -lam.real / np.abs(lam) - (-lam0.real / np.abs(lam0))
    assert added.max() == pytest.approx(0.02, rel=0.1)
    assert np.abs(psi.imag).max() > 1e-3 * np.abs(psi).max()  # non-proportional: complex shapes


def test_effect_case_names_are_the_projects(cases):
    names = {c.truth["effect"] for c in cases}
    assert names == {"none", "root_flexibility", "added_mass", "shear_deformation", "local_damping"}
    for c in cases:
        f = np.array(c.modal["natural_frequencies_hz"])
        np.testing.assert_allclose(f, c.truth["natural_frequencies_hz"], rtol=0.002)
        assert np.array(c.modal["eigenvectors"]).shape == (4, 4)


def test_effect_cases_written(cases, tmp_path):
    effects.write_effect_cases(cases[:2], tmp_path)
    table = json.loads((tmp_path / "cases.json").read_text())["cases"]
    assert [t["effect"] for t in table] == ["none", "root_flexibility"]
    freq = json.loads((tmp_path / "case-01_freq.json").read_text())
    assert set(freq) == {"natural_frequencies_hz", "damping_ratios"}
    modal = json.loads((tmp_path / "case-01_modal.json").read_text())
    lam = np.array([complex(v) for v in modal["eigenvalues"]])
    np.testing.assert_allclose(np.abs(lam) / (2 * math.pi), freq["natural_frequencies_hz"], rtol=1e-9)
    assert modal["dofs"] == ["2:y", "3:y", "4:y", "5:y"]


@pytest.fixture(scope="module")
def written_pair(tmp_path_factory):
    out = tmp_path_factory.mktemp("pairs")
    recs = pairs.simulate_pairs("timoshenko", 2, seed=4)
    pairs.write_pairs(recs, out)
    return out, recs


def test_pair_files_and_truth(written_pair):
    out, recs = written_pair
    truth = json.loads((out / "truth.json").read_text())["pairs"]
    assert [t["pair"] for t in truth] == [0, 1]
    assert (out / "truth.csv").read_text().count("\n") == 3
    for r in recs:
        for day in ("baseline", "current"):
            assert (out / f"pair-{r.pair:03d}_{day}.uff").is_file()
        if r.truth["damaged"]:
            assert r.truth["max_frequency_drop_rel"] >= 0.002
    again = pairs.simulate_pairs("timoshenko", 2, seed=4)
    np.testing.assert_array_equal(again[1].current, recs[1].current)


def test_uff_reads_back_with_pyuff(tmp_path):
    import pyuff

    f = np.arange(4, 1601) * 0.5
    rng = np.random.default_rng(0)
    H = rng.standard_normal((4, f.size)) * 1e-4 + 1j * rng.standard_normal((4, f.size)) * 1e-4
    write_uff(tmp_path / "t.uff", f, H, pairs.NODE_X_M, pairs.RESP_NODES, pairs.REF_NODE)
    uff = pyuff.UFF(str(tmp_path / "t.uff"))
    assert list(uff.get_set_types()) == [164, 15, 58, 58, 58, 58]
    sets = uff.read_sets()
    np.testing.assert_allclose(sets[1]["x"], 1000 * np.array(pairs.NODE_X_M))
    for k, s in enumerate(sets[2:]):
        assert (s["func_type"], s["rsp_node"], s["rsp_dir"], s["ref_node"], s["ordinate_spec_data_type"]) == \
               (4, pairs.RESP_NODES[k], 2, 2, 8)
        np.testing.assert_allclose(s["x"], f, rtol=1e-12)
        np.testing.assert_allclose(s["data"], H[k], rtol=1e-10)


@pytest.mark.parametrize("pair", [0, 1])  # pair 1 of the timoshenko set is written as accelerance
def test_project_reader_reads_the_written_files(written_pair, pair):
    from physics.io import read_frf

    out, recs = written_pair
    frf = read_frf(out / f"pair-{pair:03d}_current.uff")
    assert recs[pair].kind == ("accelerance" if pair else "receptance")
    np.testing.assert_allclose(frf.frequency_hz, recs[pair].freq_hz, rtol=1e-12)
    assert frf.response_dofs == ("2:+Y", "3:+Y", "4:+Y", "5:+Y") and frf.reference_dofs == ("2:+Y",)
    H = frf.to_kind("receptance").frf
    assert H.shape == (4, 1, recs[pair].freq_hz.size)
    np.testing.assert_allclose(H[:, 0, :], recs[pair].current, rtol=1e-8)


def test_imports_nothing_from_the_project():
    allowed = {"numpy", "scipy", "pyuff", "__future__"} | set(sys.stdlib_module_names)
    files = sorted(PACKAGE.glob("*.py"))
    assert len(files) >= 5
    for path in files:
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                names = [node.module or ""] if node.level == 0 else ["experiments.second_sim"]
            elif isinstance(node, ast.Call) and getattr(node.func, "attr", "") == "import_module":
                arg = node.args[0]
                names = [arg.value if isinstance(arg, ast.Constant) else "experiments.second_sim"]
                if isinstance(arg, ast.JoinedStr):
                    names = ["".join(v.value for v in arg.values if isinstance(v, ast.Constant))]
            else:
                continue
            for name in names:
                top = name.split(".")[0]
                ok = top in allowed or name == "experiments.second_sim" or name.startswith("experiments.second_sim.")
                assert ok, f"{path.name} imports {name}"


def test_cli_writes_pairs_and_refuses_a_bad_band(tmp_path, capsys):
    from experiments.second_sim.__main__ import main

    assert main(["pairs", "--set", "easy", "--n", "1", "--seed", "2", "--band-hz", "5", "400", "--df-hz", "1",
                 "--out", str(tmp_path / "p")]) == 0
    assert sorted(p.name for p in (tmp_path / "p").iterdir()) == \
        ["pair-000_baseline.json", "pair-000_baseline.uff", "pair-000_current.json", "pair-000_current.uff",
         "truth.csv", "truth.json"]
    truth = json.loads((tmp_path / "p" / "truth.json").read_text())["pairs"][0]
    for day in ("baseline", "current"):   # modal data: the truth's modes with 0.03 % frequency noise
        md = json.loads((tmp_path / "p" / f"pair-000_{day}.json").read_text())
        assert md["dofs"] == ["2:y", "3:y", "4:y", "5:y"] and len(md["eigenvectors"]) == 4
        np.testing.assert_allclose(md["natural_frequencies_hz"], truth[f"{day}_frequencies_hz"], rtol=2e-3)
    assert main(["pairs", "--band-hz", "5", "1", "--out", str(tmp_path / "q")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--band-hz" in err[0] and not (tmp_path / "q").exists()
