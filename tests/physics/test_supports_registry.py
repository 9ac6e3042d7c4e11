"""The support records (physics.supports.SUPPORTS): rigid-body modes, constrained DOFs, springs, refusals, docs."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.linalg import eigh

from physics import fem
from physics.errors import ConfigError
from physics.supports import SUPPORTS, add_springs, markdown_table, support, suspension_unit_stiffness

ROOT = Path(__file__).resolve().parents[2]

#: The DOFs each support holds on a 3-node beam, written out by hand.
HELD = {"clamped-free": {"1:y", "1:rz"}, "free-free": set(), "pinned-pinned": {"1:y", "3:y"},
        "clamped-clamped": {"1:y", "1:rz", "3:y", "3:rz"}}


def _full(n_el=6, L=1.0):
    """K and M of a free uniform beam over all DOFs (unit EI and mass per length)."""
    le = L / n_el
    K = fem.assemble(np.broadcast_to(fem.element_stiffness(1.0, le), (n_el, 4, 4)))
    M = fem.assemble(np.broadcast_to(fem.element_mass(1.0, le), (n_el, 4, 4)))
    return K, M, fem.dof_names(n_el + 1)


@pytest.mark.parametrize("name", list(SUPPORTS))
def test_rigid_body_modes_are_the_near_zero_eigenvalues_of_the_supported_beam(name):
    sup = support(name)
    K, M, names = _full()
    removed = sup.constrained_dofs(len(names) // 2)
    keep = [i for i, d in enumerate(names) if d not in removed]
    w2 = eigh(K[np.ix_(keep, keep)], M[np.ix_(keep, keep)], eigvals_only=True)
    # unit EI, m and L: the lowest bending mode has w^2 >= 1.875^4 = 12.4 (the cantilever's)
    assert np.count_nonzero(np.abs(w2) < 1e-6) == sup.rigid_body_modes
    assert np.sort(np.abs(w2))[sup.rigid_body_modes] > 12.0


@pytest.mark.parametrize("name", list(SUPPORTS))
def test_constrained_dofs_reproduce_the_supported_stiffness(name):
    assert set(support(name).constrained_dofs(3)) == HELD[name]
    model = fem.beam_model(6, 1.0, 1.0, 1.0, bc=name)
    K, _, names = _full()
    held = {d.replace("3:", "7:") for d in HELD[name]}                 # node 3 of 3 is node 7 of 7
    keep = [i for i, d in enumerate(names) if d not in held]
    np.testing.assert_array_equal(model.K, K[np.ix_(keep, keep)])
    assert model.dofs == tuple(names[i] for i in keep)


def test_the_support_springs_and_their_nominal_values():
    assert support("clamped-free").spring_dofs(5) == ("1:rz",)
    assert support("clamped-clamped").spring_dofs(5) == ("1:rz", "5:rz")
    assert support("pinned-pinned").spring_dofs(5) == ("1:rz", "5:rz")
    assert support("free-free").spring_dofs(5) == ("1:y", "5:y")
    # the default suspension: bounce sqrt(2 k / (m L)) at 5 % of the first bending frequency 22.3733 sqrt(EI/m)/L^2
    L = 0.8
    k = support("free-free").nominal_unit_stiffness(L)
    assert k == suspension_unit_stiffness(L)
    assert np.sqrt(2 * k / L) == pytest.approx(0.05 * 22.3733 / L**2, rel=1e-12)
    assert [support(n).nominal_unit_stiffness(L) for n in ("clamped-free", "pinned-pinned")] == [0.0, 0.0]
    K = add_springs(np.zeros((2, 3, 3)), ("1:y", "1:rz", "2:y"), ("1:y", "2:y"), np.array([1.0, 2.0]))
    np.testing.assert_array_equal(K[:, [0, 2], [0, 2]], [[1.0, 1.0], [2.0, 2.0]])
    assert np.count_nonzero(K) == 4


@pytest.mark.parametrize("name, message", [
    ("fixed", "'bc' = 'fixed' unknown; expected one of ['clamped-free', 'free-free', 'pinned-pinned', "
              "'clamped-clamped']"),
    ("pinned-free", "'bc' = 'pinned-free' leaves the beam a mechanism (it moves without bending); expected one of "
                    "['clamped-free', 'free-free', 'pinned-pinned', 'clamped-clamped']"),
])
def test_an_unknown_support_is_refused_in_one_line(name, message):
    with pytest.raises(ConfigError) as e:
        support(name, "bar.toml")
    assert str(e.value) == f"bar.toml: {message}"
    with pytest.raises(ConfigError, match="^'bc' = "):
        fem.beam_model(4, 1.0, 1.0, 1.0, bc=name)


def test_the_cli_refuses_an_unknown_support_in_one_line_with_exit_code_2(tmp_path):
    beam = tmp_path / "bar.toml"
    beam.write_text('bc = "fixed"\nlength_m = 1.0\nwidth_m = 0.02\nthickness_m = 0.01\nEI_Nm2 = 100.0\n'
                    'mass_per_length_kg_m = 1.0\n')
    run = subprocess.run([sys.executable, "-m", "experiments.cli", "model", "--beam", str(beam)],
                         capture_output=True, text=True, cwd=ROOT, timeout=60)
    assert run.returncode == 2
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and "'bc' = 'fixed' unknown; expected one of" in lines[0] and "bar.toml" in lines[0]
    assert run.stdout == ""


def test_the_docs_table_is_the_registry():
    assert markdown_table() in (ROOT / "docs" / "beam-file.md").read_text()
