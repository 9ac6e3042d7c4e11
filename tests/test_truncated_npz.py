"""Every command that reads an NPZ file answers a truncated one in one line with exit code 2.

A valid NPZ (FRFs, or response time records) is cut at several byte offsets (inside the first member's header,
inside its data, inside the central directory, one byte short) and given to ``identify``, ``update --modal``,
``classify``, ``discrepancy --measured`` and ``estimate`` through ``experiments.cli.main``.
"""

import numpy as np
import pytest
from test_malformed import _npz, _thesis_modal, _modal, _tiny_model, run_case

pytestmark = pytest.mark.filterwarnings("ignore")


def _time_npz(path):
    rng = np.random.default_rng(0)
    np.savez(path, signals=rng.standard_normal((2, 4000)), sampling_frequency_hz=np.array(200.0),
             dofs=np.array(["2:+Y", "5:+Y"]))
    return path


def _truncated(good, path, where):
    data = good.read_bytes()
    cut = {"member header": 40, "member data": len(data) // 2, "central directory": len(data) - 60,
           "last byte": len(data) - 1}[where]
    path.write_bytes(data[:cut])
    return str(path)


def _frf(d, where):
    return _truncated(_npz(d / "good.npz"), d / "frf.npz", where)


def _records(d, where):
    return _truncated(_time_npz(d / "good.npz"), d / "rec.npz", where)


COMMANDS = {
    "identify (FRFs)": lambda d, w: ["identify", _frf(d, w), "--json"],
    "identify (records)": lambda d, w: ["identify", _records(d, w), "--json"],
    "identify --method ssi": lambda d, w: ["identify", _records(d, w), "--method", "ssi"],
    "update --modal": lambda d, w: ["update", "--beam", "beam5", "--modal", _frf(d, w)],
    "classify": lambda d, w: ["classify", "--model", str(_tiny_model()), "--baseline", _frf(d, w),
                              str(_modal(d / "c.json", _thesis_modal())), "--json"],
    "discrepancy --measured": lambda d, w: ["discrepancy", "--beam", "beam5", "--measured", _frf(d, w)],
    "estimate": lambda d, w: ["estimate", _records(d, w)],
}


@pytest.mark.parametrize("where", ["member header", "member data", "central directory", "last byte"])
@pytest.mark.parametrize("command", list(COMMANDS))
def test_a_truncated_npz_gets_one_line_and_exit_2(tmp_path, command, where):
    code, out, err, _, created = run_case(lambda d: COMMANDS[command](d, where), tmp_path / "case")
    assert code == 2, f"exit {code!r}; stderr: {err!r}"
    assert err.count("\n") == 1 and err.endswith("\n"), f"stderr must be one line: {err!r}"
    assert ".npz" in err and "Traceback" not in err, err
    assert out == "" and created == [], (out, created)
