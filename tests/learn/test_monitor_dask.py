"""`monitor --scheduler`: a series identified on a Dask cluster gives, byte for byte, what one local process gives;
a worker that cannot read a test, or a malformed address, stops the run with one line (exit 2)."""

import json

import pytest

from experiments.cli import main
from experiments.second_sim.series import SeriesConfig, simulate_series, write_series
from learn.monitor.identification import IdentificationSettings
from learn.monitor.workers import fft_peaks_of_files, identify_files
from physics.errors import BeamDamageError

distributed = pytest.importorskip("distributed")


@pytest.fixture(scope="module")
def cluster():
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as lc:
        with distributed.Client(lc.scheduler_address) as client:
            yield lc.scheduler_address, client


@pytest.fixture(scope="module")
def records(tmp_path_factory):
    """14 output-only tests of the independent simulator's cantilever (three sensors, SSI-cov; 14 FFT-peak reads)."""
    cfg = SeriesConfig(n_tests=14, kind="output-only", damage_day=None, seed=0)
    d = write_series(cfg, simulate_series(cfg), tmp_path_factory.mktemp("records"))
    return [str(d / t["file"]) for t in json.loads((d / "truth.json").read_text())["tests"]]


def test_the_cluster_identifies_and_reads_fft_peaks_as_one_process_does(cluster, records):
    _, client = cluster
    settings = IdentificationSettings((5.0, 400.0))
    (m1, e1, p1), (m2, e2, p2) = (identify_files(records[:6], settings, None, w) for w in (1, client))
    assert e1 == e2 == [None] * 6
    assert [m.frequencies_hz.tobytes() for m in m1] == [m.frequencies_hz.tobytes() for m in m2]
    bands = [[5.0, 20.0], [50.0, 80.0], [150.0, 210.0]]
    f1, f2 = (fft_peaks_of_files(records[:6], bands, None, w) for w in (1, client))
    assert f1.tobytes() == f2.tobytes() and f1.shape == (6, 3)
    assert abs(f1[:, 0].mean() - m1[0].frequencies_hz[0]) < 0.5               # mode 1 near 10.1 Hz, read twice


@pytest.mark.slow
def test_monitor_on_a_separately_started_cluster_writes_the_json_and_cache_of_one_process(tmp_path, capsys, records):
    """`dask scheduler` and `dask worker` as a user starts them, `monitor --scheduler tcp://...`."""
    from dask_cluster import separate_cluster

    outs = {}
    with separate_cluster(2) as address:
        for how, flag in (("local", ["--workers", "1"]), ("dask", ["--scheduler", address])):
            assert main(["monitor", *records, "--baseline-tests", "10", "--band", "5", "400", *flag,
                         "--out", str(tmp_path / how), "--json"]) == 0
            outs[how] = capsys.readouterr()[0].replace(str(tmp_path / how), "OUT")
        with distributed.Client(address) as client:                 # the cluster did the work
            done = client.run_on_scheduler(lambda dask_scheduler: {k: tp.state_counts.get("memory", 0) for k, tp in
                                                                   dask_scheduler.task_prefixes.items()})
    assert done.get("on_worker", 0) >= 28                             # 14 identifications and 14 FFT-peak reads
    assert outs["local"] == outs["dask"]
    res = json.loads(outs["dask"])
    assert len(res["tests"]) == 14 and res["counts"].get("not identified", 0) == 0
    assert res["normal_variation"]["frequency_estimators"] is not None            # the FFT peaks were read too
    caches = [sorted((p.relative_to(tmp_path / how), p.read_bytes()) for p in (tmp_path / how / "cache").rglob("*")
                     if p.is_file()) for how in outs]
    assert caches[0] == caches[1] and len(caches[0]) >= 14


def test_a_file_the_workers_cannot_read_stops_the_run_naming_it(tmp_path, cluster, records):
    _, client = cluster
    missing = str(tmp_path / "not-on-the-workers.npz")
    modes, errors, _ = identify_files([records[0], missing], IdentificationSettings((5.0, 400.0)))
    assert modes[1] is None and errors[1]                # one process: a test that cannot be identified
    for run in (lambda: identify_files([records[0], missing], IdentificationSettings((5.0, 400.0)), workers=client),
                lambda: fft_peaks_of_files([missing], [[5.0, 20.0]], workers=client)):
        with pytest.raises(BeamDamageError, match="not-on-the-workers.npz; the tests must lie on a file system"):
            run()


@pytest.mark.parametrize("address, expect", [("not a url", "expected an address scheme://host:port"),
                                             ("foo://host:1", "with a scheme in tcp, tls"),
                                             ])
def test_a_malformed_address_is_one_line_and_exit_2(tmp_path, capsys, records, address, expect):
    assert main(["monitor", *records[:11], "--baseline-tests", "10", "--scheduler", address, "--json"]) == 2
    err = capsys.readouterr()[1].strip()
    assert len(err.splitlines()) == 1 and "--scheduler" in err and expect in err
