"""The file-format table :data:`physics.io.FORMATS`: the CLI's choices and help derive from it, every writer
round-trips through its reader, sniffing finds each format without its extension."""

import re

import numpy as np
import pytest

pytest.importorskip("pyuff")

from experiments.cli import COMMANDS, build_parser
from physics.errors import FileFormatError
from physics.io import (FORMATS, FRF, MODAL, TIME, MeasuredFRF, ModalData, accepted, format_of, modal_or_frf, read,
                        read_frf, writable)
from physics.modal import eigenvalues_from_modal


def _commands():
    """Every command's parser (each built as its command line builds it)."""
    subs = {name: next(a for a in build_parser([name])._actions if a.dest == "command") for name in COMMANDS}
    return {name: sub.choices[name] for name, sub in subs.items()}


def _action(command, dest):
    return next(a for a in _commands()[command]._actions if a.dest == dest)


def test_export_format_choices_are_the_registry_frf_writers():
    choices = _action("export", "format").choices
    assert sorted(choices) == sorted(f.name for f in FORMATS.values() if f.writer and f.holds[0] == FRF)
    assert sorted(choices) == ["csv", "npz", "uff"]
    assert all(f.description in _action("export", "format").help for f in writable(FRF).values())


#: Where a command says which files it reads, and what those files hold.
ACCEPTING = {("identify", "file"): (FRF,), ("estimate", "file"): (TIME,), ("update", "modal"): (MODAL, FRF),
             ("discrepancy", "measured"): (MODAL, FRF), ("classify", None): (FRF, MODAL)}


@pytest.mark.parametrize("command, dest", list(ACCEPTING))
def test_help_on_accepted_files_is_the_registry_text(command, dest):
    text = _commands()[command].description if dest is None else _action(command, dest).help
    assert accepted(*ACCEPTING[command, dest]) in text


def test_no_help_text_lists_formats_by_hand():
    """Every mention of a reading-only extension (.unv, .58b, .txt, ...) in any help text is a registry text."""
    derived = sorted({accepted(*h) for h in ACCEPTING.values()}, key=len, reverse=True)
    others = {e for f in FORMATS.values() for e in f.extensions[1:]}
    pattern = re.compile("|".join(re.escape(e) + r"\b" for e in sorted(others)) + r"|UFF ?58")
    for name, parser in _commands().items():
        for text in [parser.description or ""] + [a.help or "" for a in parser._actions]:
            for d in derived:
                text = text.replace(d, "")
            assert not pattern.search(text), f"{name}: {text!r}"


def _frf():
    f_hz = np.arange(1.0, 60.0, 0.5)
    w, wn = 2 * np.pi * f_hz, 2 * np.pi * np.array([[12.0], [31.0]])
    h = 1.0 / (0.2 * (wn**2 - w**2 + 2j * 0.01 * wn * w))
    return MeasuredFRF(f_hz, h[:, None, :], ("2:+Y", "3:+Y"), ("2:+Y",), metadata={"id1": "round trip"})


def _modal():
    lam = eigenvalues_from_modal(np.array([12.0, 31.0]), np.array([0.01, 0.02]))
    return ModalData(lam, np.array([[1.0 + 0.1j, -0.4 + 0.0j], [0.7 - 0.05j, 1.0 + 0.2j]]), ("2:y", "3:y"))


@pytest.mark.parametrize("name", [n for n, f in FORMATS.items() if f.writer is not None])
def test_every_writer_round_trips_through_its_reader_and_sniffing(tmp_path, name):
    fmt = FORMATS[name]
    data = _frf() if fmt.holds[0] == FRF else _modal()
    named = tmp_path / f"x{fmt.extensions[0]}"
    fmt.writer(named, data)
    unnamed = tmp_path / "x.dat"
    unnamed.write_bytes(named.read_bytes())
    assert format_of(named, fmt.holds[0]) is fmt and format_of(unnamed, fmt.holds[0]) is fmt
    assert modal_or_frf(named) == modal_or_frf(unnamed) == (MODAL if name == "json" else FRF)
    for back in (read(named, fmt.holds[0]), read(unnamed, fmt.holds[0])):
        if fmt.holds[0] == FRF:
            assert (back.response_dofs, back.reference_dofs, back.kind) == (data.response_dofs,
                                                                            data.reference_dofs, data.kind)
            assert back.metadata["format"] == name
            np.testing.assert_allclose(back.frequency_hz, data.frequency_hz, rtol=1e-12)
            np.testing.assert_allclose(back.frf, data.frf, rtol=1e-10, atol=1e-11 * np.abs(data.frf).max())
        else:
            assert back.dofs == data.dofs
            np.testing.assert_allclose(back.eigenvalues, data.eigenvalues, rtol=1e-12)
            np.testing.assert_allclose(back.eigenvectors, data.eigenvectors, rtol=1e-12)


def test_a_file_of_another_content_is_named_with_what_was_expected(tmp_path):
    FORMATS["json"].writer(tmp_path / "m.dat", _modal())
    with pytest.raises(FileFormatError, match=r"m.dat: looks like JSON \(modal data\); expected FRFs as UFF"):
        read_frf(tmp_path / "m.dat")
    FORMATS["json"].writer(tmp_path / "n.dat", _modal())
    with pytest.raises(FileFormatError, match=r"looks like JSON \(modal data\); expected time records as UFF \(.uff/"):
        read(tmp_path / "n.dat", TIME)
    FORMATS["csv"].writer(tmp_path / "f.dat", _frf())      # CSV holds time series too: its header is refused
    with pytest.raises(FileFormatError, match=r"f.dat: expected a header 'time_s,<dof>"):
        read(tmp_path / "f.dat", TIME)
    (tmp_path / "g.dat").write_bytes(bytes(range(128, 256)))
    with pytest.raises(FileFormatError, match="is of no known format"):
        read_frf(tmp_path / "g.dat")
    with pytest.raises(FileFormatError, match="is a directory"):
        read_frf(tmp_path)
