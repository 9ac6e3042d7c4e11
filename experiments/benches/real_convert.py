"""The real repeated-test sets of ``experiments/data/real/README.md`` converted from their public repositories.

Run: ``python -m experiments.benches.real_convert SET [SET ...] --source DIR [--out experiments/data/real]``

``DIR`` is a checkout of the set's repository at the commit of :data:`SETS` (``git clone URL DIR && git -C DIR
checkout COMMIT``; some files were removed from the repositories later). Each set's converter reads the files of
its entry (``paths``, relative to ``DIR``) as they are (float64 as written, no scaling) and writes ``<SET>.npz``
(compressed, atomically) into ``--out``. A file absent or not of the expected form stops with one line naming it
(exit code 2) and writes nothing.
"""

from __future__ import annotations

import io
import re
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np
import pandas as pd

from experiments.benches.harness import parser
from physics.errors import BeamDamageError, ConfigError, FileFormatError
from physics.io import atomic_write_bytes

__all__ = ["BRIDGE_TESTS", "DROPBEAR_STATE_PINLOC_V", "DS11_BOARDS", "DS11_MORE_BOARDS", "DS11_OPEN_CIRCUIT_OHM",
           "RealSet", "SETS", "convert_set", "dropbear_dwells", "main", "read_lvm", "write_npz"]

OUT = Path(__file__).resolve().parents[1] / "data" / "real"

#: PinLoc voltage (V) of the DROPBEAR roller's six support positions, state 0 to 5 (the medians of the dwells).
DROPBEAR_STATE_PINLOC_V = np.array([1.2259, 1.6472, 2.0835, 2.5035, 2.9355, 3.3693])


@dataclass(frozen=True)
class RealSet:
    """One set: where its files come from and how they become its ``.npz``.

    Attributes
    ----------
    name : str                  the file ``<name>.npz`` and the command line's ``SET``
    repository : str            GitHub ``owner/name``
    commit : str                the commit whose files are read (40 hex digits)
    paths : tuple of str        the files read, relative to the repository's root, in the converter's order
    licence : str               the files' licence at that commit
    convert : callable          ``convert(files)`` -> dict of arrays, ``files`` the ``paths`` under the checkout
    """

    name: str
    repository: str
    commit: str
    paths: tuple
    licence: str
    convert: Callable[[list], dict]


# --- readers -----------------------------------------------------------------------------------------------------

def _text(path: Path) -> str:
    try:
        return path.read_text(encoding="utf-8", errors="strict")
    except UnicodeDecodeError as exc:
        raise FileFormatError(f"{path}: not UTF-8 text ({exc.reason} at byte {exc.start})") from None


def read_lvm(path) -> tuple[float, str, str, pd.DataFrame]:
    """``(Delta_X (s), Y_Unit_Label, "date time" of the header (time to 12 characters), data columns)`` of a LabVIEW
    measurement text file (comma separator, one X column); the columns without ``X_Value`` and ``Comment``."""
    path = Path(path)
    lines = _text(path).splitlines()
    k = next((j for j, s in enumerate(lines) if s.startswith("X_Value")), None)
    if k is None:
        raise FileFormatError(f"{path}: no 'X_Value' heading line; expected a LabVIEW measurement (.lvm) text file")
    head = {}
    for s in lines[:k]:
        key, _, rest = s.partition(",")
        head[key] = rest.split(",")[0]                     # the last occurrence: the channel header's
    missing = [key for key in ("Delta_X", "Y_Unit_Label", "Date", "Time") if key not in head]
    if missing:
        raise FileFormatError(f"{path}: header field(s) {', '.join(missing)} missing")
    try:
        df = pd.read_csv(io.StringIO("\n".join(lines[k:])))
    except ValueError as exc:                              # pandas' ParserError is one
        raise FileFormatError(f"{path}: not a comma-separated table ({' '.join(str(exc).split())})") from None
    data = df.drop(columns=[c for c in df.columns if c in ("X_Value", "Comment")])
    text = [c for c in data.columns if data[c].dtype.kind not in "fiu"]
    if text:
        raise FileFormatError(f"{path}: column(s) {', '.join(map(str, text))} hold text; expected numbers")
    return float(head["Delta_X"]), head["Y_Unit_Label"], f"{head['Date']} {head['Time'][:12]}", data


def _expect(path, what: str, got, expected) -> None:
    if got != expected:
        raise FileFormatError(f"{path}: {what} {got!r}; expected {expected!r}")


def _same_length(files, arrays, what: str) -> np.ndarray:
    """``arrays`` stacked; one line naming the first file whose shape differs from the first's."""
    for f, a in zip(files, arrays):
        if a.shape != arrays[0].shape:
            raise FileFormatError(f"{f}: {what} of shape {a.shape}; {files[0]} has {arrays[0].shape}")
    return np.asarray(arrays, float)


def _columns(path, text: str, skiprows: int, n_columns: int, first_only: bool = False) -> np.ndarray:
    """The table of numbers in ``text`` after ``skiprows`` lines: ``n_columns`` columns (``first_only``: the first
    ``n_columns`` of each line, later numbers on some lines ignored)."""
    try:
        x = np.loadtxt(io.StringIO(text), skiprows=skiprows, ndmin=2,
                       usecols=tuple(range(n_columns)) if first_only else None)
    except ValueError as exc:
        raise FileFormatError(f"{path}: not a table of numbers ({' '.join(str(exc).split())})") from None
    if x.shape[1] != n_columns or x.shape[0] < 2:
        raise FileFormatError(f"{path}: {x.shape[0]} rows of {x.shape[1]} columns; expected {n_columns} columns")
    return x


# --- the sets --------------------------------------------------------------------------------------------------------

def _pyfrf(files) -> dict:
    """Five hammer hits: each ``.npy`` (3, n) rows time (s), excitation, response."""
    m = []
    for f in files:
        try:
            x = np.load(f, allow_pickle=False)
        except ValueError as exc:
            raise FileFormatError(f"{f}: not a NumPy array file ({' '.join(str(exc).split())})") from None
        if x.ndim != 2 or x.shape[0] != 3:
            raise FileFormatError(f"{f}: array of shape {x.shape}; expected (3, n): time, excitation, response")
        m.append(x)
    m = _same_length(files, m, "array")
    fs = 1.0 / float(np.mean(np.diff(m[0, 0])))
    return {"force": m[:, 1], "response": m[:, 2], "sampling_frequency_hz": np.float64(round(fs, 6)),
            "dof_labels": np.array(["excitation", "response"])}


def _hct(files) -> dict:
    """Heritage Court Tower: one whitespace-separated column per channel, 40 Hz."""
    setups = []
    for f in files:
        try:
            setups.append(np.loadtxt(f, ndmin=2).T)
        except ValueError as exc:
            raise FileFormatError(f"{f}: not a table of numbers ({' '.join(str(exc).split())})") from None
    labels = {f"dof_labels_setup{i + 1}": np.array([f"setup{i + 1}:ch{c + 1}" for c in range(y.shape[0])])
              for i, y in enumerate(setups)}
    return {**{f"setup{i + 1}": y for i, y in enumerate(setups)}, **labels, "sampling_frequency_hz": np.float64(40.0)}


def dropbear_dwells(pinloc_v, sampling_frequency_hz: float, window: int = 250, tol_v: float = 0.03,
                    min_s: float = 0.55) -> list:
    """The dwells of the DROPBEAR roller: ``(start, stop, median PinLoc V)`` of each run of samples (stop exclusive)
    at least ``min_s`` (s) long where the ``window``-sample moving average of the PinLoc voltage ``pinloc_v`` (n,)
    changes by at most ``tol_v`` (V) within 0.05 s either way (the first and last ``window`` samples excluded)."""
    pin = np.asarray(pinloc_v, float)
    pm = np.convolve(pin, np.ones(window) / window, mode="same")
    lag = int(0.05 * sampling_frequency_hz)
    d = np.abs(pm[lag:] - pm[:-lag])
    moving = np.r_[np.zeros(lag, bool), d > tol_v] | np.r_[d > tol_v, np.zeros(lag, bool)]
    still = ~moving
    still[:window] = False
    still[-window:] = False
    idx = np.flatnonzero(np.diff(np.r_[0, still.astype(int), 0]))
    return [(a, b, float(np.median(pin[a:b]))) for a, b in zip(idx[::2], idx[1::2])
            if (b - a) / sampling_frequency_hz >= min_s]


def _dropbear(files) -> dict:
    """DROPBEAR 10-step tests: 9 header lines (line 4 ``Sampling Frequency - 5000``, line 6 the column names), then
    tab-separated ``Low G Accel, Accel, PinLoc, Time``; records cut to the shortest, dwells found on PinLoc."""
    fs = 5000.0
    recs, segs = [], []
    for i, f in enumerate(files):
        text = _text(f)
        head = text.splitlines()[:9]
        if len(head) < 9 or "Sampling Frequency - 5000" not in head[3]:
            raise FileFormatError(f"{f}: line 4 {head[3] if len(head) > 3 else ''!r}; expected "
                                  "'Sampling Frequency - 5000'")
        _expect(f, "columns", head[5].split("\t")[:4], ["Low G Accel", "Accel", "PinLoc", "Time"])
        x = _columns(f, text, 9, 4)
        if not np.allclose(np.diff(x[:, 3]), 1 / fs, atol=1e-7):
            raise FileFormatError(f"{f}: time column not on a {1 / fs:g} s step")
        recs.append(x[:, :3].T)
        segs += [(i, a, b, m) for a, b, m in dropbear_dwells(x[:, 2], fs)]
    n = min(r.shape[1] for r in recs)
    segs = np.array(segs, float).reshape(-1, 4)
    state = np.argmin(np.abs(segs[:, 3:4] - DROPBEAR_STATE_PINLOC_V[None, :]), axis=1)
    return {"records": np.asarray([r[:, :n] for r in recs], float), "sampling_frequency_hz": np.float64(fs),
            "dof_labels": np.array(["low_g_accel_V", "shock_accel_V", "roller_pinloc_V"]),
            "test_number": np.array([int(re.search(r"(\d+)\.txt$", str(f)).group(1)) for f in files], np.int64),
            "segment_test": segs[:, 0].astype(np.int64), "segment_start": segs[:, 1].astype(np.int64),
            "segment_stop": segs[:, 2].astype(np.int64), "segment_pinloc_v": segs[:, 3],
            "segment_state": state.astype(np.int64), "state_pinloc_v": DROPBEAR_STATE_PINLOC_V.copy()}


#: USC bridge A, modal analysis: (file number, folder) of each impact test.
BRIDGE_TESTS = ((1, "Mode 1"), (2, "Mode 1"), (3, "Mode 2"), (4, "Mode 2"), (5, "Mode 3"), (7, "Mode 3"),
                (8, "Mode 3"), (9, "Mode 3"), (10, "Mode 3"), (11, "Mode 3"), (12, "Mode 3"), (13, "Mode 3"))
BRIDGE_DT_S, BRIDGE_AMBIENT_DT_S = 0.000156, 0.000605


def _bridge(files) -> dict:
    """USC bridge A: the impact tests (3 channels, g) then the 3 ambient records (their first channel, cut to the
    shortest)."""
    n = len(BRIDGE_TESTS)
    recs, stamps = [], []
    for f in files[:n]:
        dx, unit, start, data = read_lvm(f)
        _expect(f, "Delta_X", dx, BRIDGE_DT_S)
        _expect(f, "Y_Unit_Label", unit, "g")
        _expect(f, "number of channels", data.shape[1], 3)
        recs.append(data.to_numpy(float).T)
        stamps.append(start)
    amb, amb_stamps = [], []
    for f in files[n:]:
        dx, unit, start, data = read_lvm(f)
        _expect(f, "Delta_X", dx, BRIDGE_AMBIENT_DT_S)
        _expect(f, "Y_Unit_Label", unit, "g")
        amb.append(data.to_numpy(float)[:, 0])
        amb_stamps.append(start)
    la = min(len(a) for a in amb)
    return {"records": _same_length(files[:n], recs, "records"), "sampling_frequency_hz": np.float64(1 / BRIDGE_DT_S),
            "dof_labels": np.array(["accel_0_g", "accel_1_g", "accel_2_g"]),
            "test_number": np.array([t for t, _ in BRIDGE_TESTS], np.int64),
            "sensor_layout": np.array([fo for _, fo in BRIDGE_TESTS]), "start_time": np.array(stamps),
            "ambient_records": np.asarray([a[:la] for a in amb], float),
            "ambient_sampling_frequency_hz": np.float64(1 / BRIDGE_AMBIENT_DT_S),
            "ambient_start_time": np.array(amb_stamps)}


DS5_IMPEDANCE_FS_HZ = 51200.0


def _ds5_impedance(files) -> dict:
    """DS5 dataset-2: 32 shocks, ``Acceleration_0`` (table) and ``Acceleration_1`` (PCB), m/s^2, and the
    impedance after each shock in the first 5 rows of ``Untitled`` (Hz), ``Untitled 1``, ``Untitled 2`` (deg)."""
    recs, zmag, zph, zf = [], [], [], None
    for f in files:
        dx, _, _, data = read_lvm(f)
        _expect(f, "Delta_X", dx, 1 / DS5_IMPEDANCE_FS_HZ)
        cols = ["Acceleration_0", "Acceleration_1", "Untitled", "Untitled 1", "Untitled 2"]
        missing = [c for c in cols if c not in data.columns]
        if missing:
            raise FileFormatError(f"{f}: column(s) {', '.join(missing)} missing")
        recs.append(data[cols[:2]].to_numpy(float).T)
        e = data[cols[2:]].iloc[:5].to_numpy(float)
        zf = e[:, 0] if zf is None else zf
        if not np.array_equal(zf, e[:, 0]):
            raise FileFormatError(f"{f}: impedance frequencies {e[:, 0].tolist()}; {files[0]} has {zf.tolist()}")
        zmag.append(e[:, 1])
        zph.append(e[:, 2])
    number = np.array([int(re.search(r"Test_(\d+)\.lvm$", str(f)).group(1)) for f in files], np.int64)
    return {"records": _same_length(files, recs, "records"), "sampling_frequency_hz": np.float64(DS5_IMPEDANCE_FS_HZ),
            "dof_labels": np.array(["table_accel_ms2", "pcb_accel_ms2"]), "test_number": number,
            "acquisition_flagged_bad": np.isin(number, [17, 24]), "impedance_frequency_hz": zf,
            "impedance_magnitude": np.asarray(zmag), "impedance_phase_deg": np.asarray(zph)}


def _two_columns(f) -> tuple[np.ndarray, float]:
    """``(acceleration, mean time step (s))`` of a two-column text file (time s, acceleration) on an even grid."""
    x = _columns(f, _text(f), 0, 2)
    dt = np.diff(x[:, 0])
    if not np.ptp(dt) < 1e-3 * dt.mean():
        raise FileFormatError(f"{f}: time steps {dt.min():g}-{dt.max():g} s; expected an even grid")
    return x[:, 1], float(dt.mean())


def _ds5_shock(files) -> dict:
    """DS5 dataset-1 repeated shocks: ``acc_pcb_a<N>.txt`` then ``acc_base_a<N>.txt`` of the same trials, each cut
    to its channel's shortest file; each file's rate from its mean time step."""
    half = len(files) // 2
    trials = [int(re.search(r"a(\d+)\.txt$", str(f)).group(1)) for f in files[:half]]
    pcb, dtp = zip(*(_two_columns(f) for f in files[:half]))
    base, dtb = zip(*(_two_columns(f) for f in files[half:]))
    return {"pcb_records": np.asarray([x[:min(map(len, pcb))] for x in pcb], float),
            "base_records": np.asarray([x[:min(map(len, base))] for x in base], float),
            "pcb_original_length": np.asarray([len(x) for x in pcb], np.int64),
            "base_original_length": np.asarray([len(x) for x in base], np.int64),
            "pcb_sampling_frequency_hz": 1 / np.asarray(dtp), "base_sampling_frequency_hz": 1 / np.asarray(dtb),
            "trial_number": np.asarray(trials, np.int64), "units": np.array("g")}


#: Dataset-11: (board, file name before ``_NN.lvm``, number of files ``_00`` ...) of each board of
#: ``ds11_pcb_impacts_to_failure`` (boards 4.3, 4.4, 4.6) and of ``ds11_more_boards`` (the repository's other seven).
DS11_BOARDS = (("4.3", "HM4_b03_100mO_#8_12in_16thflt_wR2841", 50),
               ("4.4", "HM4_b04_100mO_#8_12in_16thflt_wR2841", 58),
               ("4.6", "HM4_b06_100mO_#8_12in_16thflt_wR2841", 78))
DS11_MORE_BOARDS = (("3.4", "HM_b04_100mO_#8_12in_16thflt_wR2841", 43),
                    ("4.1", "HM4_b01_100mO_#7_12in_16thflt_wR2841", 25),
                    ("4.5", "HM4_b05_100mO_#8_12in_16thflt_wR2841", 83),
                    ("4.7", "HM4_b07_100mO_#8_12in_16thflt_wR2841", 32),
                    ("4.8", "HM4_b08_100mO_#8_12in_16thflt_wR2841", 37),
                    ("4.9", "HM4_b09_100mO_#8_12in_16thflt_wR2841", 27),
                    ("4.10", "HM4_b10_100mO_#8_12in_16thflt_wR2841", 39))
DS11_DT_S = 5e-6
#: A resistance above this (ohm) is an open circuit (LabVIEW writes 9.9e37): the resistor's joint has failed.
DS11_OPEN_CIRCUIT_OHM = 1e3


def _ds11(files) -> dict:
    """Dataset-11 impacts to failure: each ``.lvm`` tab-separated, no header: time (s, 5 us step), two channels, and
    on the first line only a fourth value, the resistance (ohm) of the monitored resistor; the files of boards
    4.7-4.10 have a fifth column, further resistance readings on their first lines (not read)."""
    recs, res = [], []
    for f in files:
        text = _text(f)
        first, _, rest = text.partition("\n")
        try:
            head = [float(v) for v in first.split("\t")]
        except ValueError:
            head = []
        if len(head) not in (4, 5):
            raise FileFormatError(f"{f}: first line {first[:60]!r}; expected 4 tab-separated numbers: time, two "
                                  "channels, resistance (and a fifth, a resistance reading)")
        x = np.r_[np.array(head[:3])[None], _columns(f, rest, 0, 3, first_only=len(head) == 5)]
        if not np.allclose(np.diff(x[:, 0]), DS11_DT_S, rtol=0, atol=1e-6):
            raise FileFormatError(f"{f}: time column not on a {DS11_DT_S:g} s step")
        recs.append(x[:, 1:].T)
        res.append(head[3])
    res = np.asarray(res, float)
    return {"records": _same_length(files, recs, "records"), "sampling_frequency_hz": np.float64(1 / DS11_DT_S),
            "dof_labels": np.array(["channel_1", "board_accel"]),
            "board": np.array([Path(f).parent.name.removeprefix("Board ") for f in files]),
            "impact_number": np.array([int(re.search(r"_(\d+)\.lvm$", str(f)).group(1)) for f in files], np.int64),
            "resistance_ohm": res, "open_circuit": res > DS11_OPEN_CIRCUIT_OHM}


def _ds11_paths(boards) -> tuple:
    """The files of ``boards`` (entries of :data:`DS11_BOARDS`), board by board, each in impact order."""
    return tuple(f"Data/Board {b}/{stem}_{i:02d}.lvm" for b, stem, n in boards for i in range(n))


_DS11 = "High-Rate-SHM-Working-Group/Dataset-11-rectangular-electronic-SMD-assembly-under-repeated-5-kg-impacts"
_DS11_COMMIT = "364cb81e7ea5c570a6419182c70c9e2131bd4303"
_DS11_LICENCE = "CC BY-SA 4.0 (README; LICENSE: CC0 1.0)"
_D8 = "data/Slow Postional Displacement/trial data/10steps"
_DS1 = "data/dataset-1/data-1/PCB repeated shock trials"
_DS5_TRIALS = tuple(n for n in range(53) if n not in (44, 51))
_CC_BY_SA = "CC BY-SA 4.0 (LICENSE.txt)"

#: Every set: its source and converter (``experiments/data/real/README.md`` documents each).
SETS = {s.name: s for s in (
    RealSet("pyfrf_hits", "ladisk/pyFRF", "55431fd3c328ddc719232cc34b891291c9982a2e",
            tuple(f"data/measurements_{i}.npy" for i in range(1, 6)), "LGPL-3.0 (LICENSE at that commit)", _pyfrf),
    RealSet("hct_setups", "dagghe/pyOMA2", "7f01cfc7311f50c5bdb87190a1ab76428756c583",
            tuple(f"test_pyOMA/test_data/HTC/dherita{i}.asc" for i in range(1, 5)), "MIT (LICENSE at that commit)",
            _hct),
    RealSet("dropbear_roller_steps",
            "High-Rate-SHM-Working-Group/Dataset-8-DROPBEAR-Acceleration-vs-Roller-Displacement",
            "28955a71b7b00cbca47dec9f0ff8fd9adc591cf3", tuple(f"{_D8}/test{i}.txt" for i in range(11)), _CC_BY_SA,
            _dropbear),
    RealSet("usc_bridge_a_impacts", "ARTS-Laboratory/USC-walking-bridges", "ce26e521d23f53e66b00715a9a8b08444633e2fe",
            tuple(f"Bridge_A/modal_analysis/{fo}/TestBridge_{n}.lvm" for n, fo in BRIDGE_TESTS)
            + tuple(f"Bridge_A/Test Data/Ambient Bridge Test/testVI{s}.lvm" for s in ("", "_1", "_2")), _CC_BY_SA,
            _bridge),
    RealSet("ds5_pcb_repeated_shock", "High-Rate-SHM-Working-Group/Dataset-5-Extended-Impact-Testing",
            "1bbfcf17dfd78a09790aa092a5dc07e6a6bae628",
            tuple(f"{_DS1}/acc_pcb_a{n}.txt" for n in _DS5_TRIALS) + tuple(f"{_DS1}/acc_base_a{n}.txt"
                                                                           for n in _DS5_TRIALS), _CC_BY_SA,
            _ds5_shock),
    RealSet("ds5_pcb_shock_impedance", "High-Rate-SHM-Working-Group/Dataset-5-Extended-Impact-Testing",
            "1bbfcf17dfd78a09790aa092a5dc07e6a6bae628",
            tuple(f"data/dataset-2/data-1/Test_{i:03d}.lvm" for i in range(1, 33)), _CC_BY_SA, _ds5_impedance),
    RealSet("ds11_pcb_impacts_to_failure", _DS11, _DS11_COMMIT, _ds11_paths(DS11_BOARDS), _DS11_LICENCE, _ds11),
    RealSet("ds11_more_boards", _DS11, _DS11_COMMIT, _ds11_paths(DS11_MORE_BOARDS), _DS11_LICENCE, _ds11),
)}


def write_npz(path, arrays: dict) -> Path:
    """``arrays`` as a compressed ``.npz`` at ``path``, written atomically (no pickled objects)."""
    buf = io.BytesIO()
    np.savez_compressed(buf, **arrays)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_bytes(path, buf.getvalue())
    return path


def convert_set(name: str, source, out=OUT) -> Path:
    """Convert set ``name`` of :data:`SETS` from ``source`` (a checkout of its repository at its commit) into
    ``out/<name>.npz``; returns the path written.

    Raises :class:`ConfigError` for an unknown set, :class:`FileFormatError` naming the first file absent (and the
    commit to check out) or malformed.
    """
    if name not in SETS:
        raise ConfigError(f"set {name!r}: expected one of {', '.join(SETS)}", parameter="name")
    spec = SETS[name]
    source = Path(source)
    files = [source / p for p in spec.paths]
    absent = [f for f in files if not f.is_file()]
    if absent:
        raise FileFormatError(f"{absent[0]}: absent ({len(absent)} of the {len(files)} files of {name}); expected a "
                              f"checkout of github.com/{spec.repository} at commit {spec.commit}")
    arrays = spec.convert(files)
    bad = [k for k, v in arrays.items() if v.dtype == object]
    if bad:
        raise FileFormatError(f"{name}: field(s) {', '.join(bad)} hold Python objects; expected numbers or text")
    return write_npz(Path(out) / f"{name}.npz", arrays)


def main(argv=None) -> int:
    p = parser(__file__, __doc__, out=str(OUT))
    p.add_argument("sets", nargs="+", choices=list(SETS), metavar="SET", help=f"one of {', '.join(SETS)}")
    p.add_argument("--source", required=True, help="checkout of the set's repository at the commit of its entry")
    args = p.parse_args(argv)
    try:
        for name in args.sets:
            print(convert_set(name, args.source, args.out))
    except BeamDamageError as exc:
        sys.stderr.write(f"real_convert: error: {' '.join(str(exc).split())}\n")
        return 2
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
