"""Shard scheduling: in-process, a local process pool, or a Dask distributed cluster.

Shard ``i`` holds samples ``[i*S, min((i+1)*S, N))`` (``S = output.shard_size``)
and draws its random numbers from ``SeedSequence(seed, spawn_key=(i,))``, so
its content depends only on (config, seed, i): never on the number of workers,
the scheduler or the order in which shards finish. Workers compute; the
calling process alone writes shards and the manifest.
"""

from __future__ import annotations

import contextlib
import errno
import io
import json
import math
import shutil
import sys
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

from datagen.cluster import connect
from datagen.config import validate
from datagen.lock import LOCK_NAME, LockedError, dataset_lock
from datagen.pipeline import simulate_shard
from datagen.setup import get_setup
from datagen.warm_pool import run_warm_pool
from datagen.store import ARRAYS, DERIVED, DATASET_FORMAT, STATES, column_units, dataset_identity, file_sha256, \
    finalize, package_version, read_manifest, recover, sample_table, shard_arrays, write_manifest, write_shard
from physics.errors import BeamDamageError, ConfigError, OverdampedError
from physics.io import atomic_write_bytes

__all__ = ["BYTES_PER_SAMPLE", "check_arguments", "compute_shard", "generate", "open_or_create", "shard_plan",
           "write_omega"]


def shard_plan(n: int, shard_size: int) -> list[tuple[int, int, int]]:
    """``(index, first_sample_id, n_samples)`` of every shard."""
    return [(i, i * shard_size, min(shard_size, n - i * shard_size)) for i in range(math.ceil(n / shard_size))]


def compute_shard(cfg_json: str, seed: int, index: int, first_id: int, n: int):
    """Simulate one shard (pure function of its arguments; runs on any worker).

    Returns
    -------
    table : pandas.DataFrame
    arrays : dict of ndarray
    """
    cfg = json.loads(cfg_json)
    setup = get_setup(cfg)
    with threadpool_limits(1):  # one BLAS thread per process: shards are the parallel unit
        try:
            labels, out = simulate_shard(setup, np.random.SeedSequence(seed, spawn_key=(index,)), n)
        except OverdampedError:  # the updating's input check: a noisy measured frequency fell to <= 0
            meas = cfg["measurement"]
            raise ConfigError(f"shard {index}: the config's modal noise drives measured natural frequencies to <= 0 "
                              f"(measurement.modal_noise {meas['modal_noise']!r}, frequency_noise "
                              f"{meas['frequency_noise']}, modal_noise_scale {meas['modal_noise_scale']}); lower "
                              f"measurement.frequency_noise or modal_noise_scale") from None
    return sample_table(labels, out, index, first_id, setup.length_m, setup.damage), shard_arrays(labels, out)


def _schema() -> dict:
    return {name: {"axes": axes, "description": desc, "stored": name in ARRAYS}
            for name, (axes, desc) in {**ARRAYS, **DERIVED}.items()}


def measured_dof_names(setup) -> list:
    """Names of the measured DOFs: the thesis's nodes 2..5 of its 4-element grid, else the truth mesh's nodes."""
    if setup.test.thesis:
        return ["2:y", "3:y", "4:y", "5:y"]
    n = setup.n_elements
    return [f"{1 + int(round(x / setup.length_m * n))}:y" for x in sorted(setup.test.sensors_x_m)]


def reference_dof_name(setup) -> str:
    """Name of the reference DOF: a measured DOF's, or (no sensor there) the truth mesh's node nearest to it."""
    if not setup.drive_off_sensors:
        return measured_dof_names(setup)[setup.drive_row]
    return f"{1 + int(round(setup.test.drive_x_m / setup.length_m * setup.n_elements))}:y"


def update_statement(setup) -> str:
    """What the Lancaster/Pilkey update of a dataset uses, in one sentence."""
    S, m = setup.n_meas, setup.n_modes
    if not setup.n_update:
        return (f"no updated model: the band holds {m} mode(s) the sensors see and there are {S} sensors; "
                "Lancaster/Pilkey needs at least as many modes as DOFs (the 'updated' route is unavailable)")
    extra = f" (of the {m} measured)" if m > S else ""
    return f"Lancaster/Pilkey on the {S} lowest modes{extra} over the {S} sensors"


def write_omega(root, cfg: dict) -> bool:
    """Write ``omega_rad_s.npy`` as the config defines it unless the file already holds exactly that.

    Returns True when the file was (re)written. A resumed run thus repairs a damaged file instead of
    recording its checksum.
    """
    buf = io.BytesIO()
    np.save(buf, get_setup(cfg).omega_rad_s, allow_pickle=False)
    p = Path(root) / "omega_rad_s.npy"
    try:
        if p.read_bytes() == buf.getvalue():
            return False
    except FileNotFoundError:
        pass
    atomic_write_bytes(p, buf.getvalue())
    return True


#: Disk bytes per sample without stored FRFs (shard arrays and table rows; measured: about 3.3 kB + the rows).
BYTES_PER_SAMPLE = 4500


def check_arguments(cfg: dict, n: int, seed: int, workers: int, root=None) -> None:
    """Refuse impossible ``n``/``seed``/``workers`` and a dataset larger than the free disk space (one line)."""
    def integer(v):
        return isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_))

    if not integer(n) or n < 1:
        raise BeamDamageError(f"number of samples n must be an integer >= 1, got {n!r}", parameter="n")
    if not integer(seed) or seed < 0:
        raise BeamDamageError(f"seed must be an integer >= 0 (numpy SeedSequence), got {seed!r}", parameter="seed")
    if not integer(workers) or workers < 1:
        raise BeamDamageError(f"workers must be an integer >= 1, got {workers!r}", parameter="workers")
    out = cfg["output"]
    per_sample = BYTES_PER_SAMPLE + (2 * 2 * 4 * cfg["measurement"]["lines"] * np.dtype(out["frf_dtype"]).itemsize
                                     if out["store_frf"] else 0)
    need = n * per_sample
    if root is not None:
        existing = Path(root).resolve()
        while not existing.exists() and existing != existing.parent:
            existing = existing.parent
        free = shutil.disk_usage(existing).free
        if need > free and not (Path(root) / "manifest.json").exists():
            raise BeamDamageError(f"n = {n} samples need about {need / 1e9:.3g} GB ({per_sample} bytes each) but "
                                  f"{existing} has {free / 1e9:.3g} GB free", parameter="n")


def _differing(a, b, where: str = "") -> list:
    """The dotted keys at which two configs differ (``beam.length_m``, ``damage.kind``), in order."""
    if isinstance(a, dict) and isinstance(b, dict):
        return [d for k in dict.fromkeys([*a, *b]) for d in _differing(a.get(k), b.get(k), f"{where}{k}.")]
    return [] if a == b else [where.rstrip(".") or "the whole config"]


def open_or_create(root, cfg: dict, seed: int, n: int) -> dict:
    """Manifest of an existing compatible run (recovered: damaged shards are dropped for regeneration) or a new one."""
    root = Path(root)
    _remove_stale_temporaries(root)
    if (root / "manifest.json").exists() and not _truncated_manifest(root):
        m = read_manifest(root, formats=(DATASET_FORMAT,))
        for key, want in (("config", cfg), ("seed", seed), ("n_requested", n)):
            if m.get(key) != want:
                what = (f"config ({', '.join(_differing(m.get(key), want)[:3])})" if key == "config" else
                        f"{'--seed' if key == 'seed' else '--n'} ({m.get(key)}, not {want})")
                raise ConfigError(f"{root} holds a dataset generated with another {what}; resume needs the same "
                                  "config, seed and --n (or choose a new --out)")
        m, damaged = recover(root, m)
        if damaged:
            print(f"{root}: {len(damaged)} damaged shard(s) {damaged} will be regenerated", file=sys.stderr)
        if write_omega(root, cfg):
            m["complete"] = False
            print(f"{root / 'omega_rad_s.npy'}: missing or damaged; rewritten from the config", file=sys.stderr)
        return m
    rebuild = (root / "manifest.json").exists()
    if not rebuild and root.exists() and any(not p.name.startswith(LOCK_NAME) for p in root.iterdir()):
        raise BeamDamageError(f"{root} exists, is not empty and has no manifest.json; choose a new --out")
    root.mkdir(parents=True, exist_ok=True)
    setup = get_setup(cfg)
    write_omega(root, cfg)
    dofs = measured_dof_names(setup)
    m = {"format": DATASET_FORMAT, "identity": dataset_identity(cfg, seed), "package_version": package_version(),
         "config": cfg, "seed": seed, "n_requested": n,
         "shard_size": cfg["output"]["shard_size"], "n_shards": len(shard_plan(n, cfg["output"]["shard_size"])),
         "complete": False, "shards": [], "schema": {"arrays": _schema(), "states": list(STATES),
                                                     "columns": column_units(setup.damage),
                                                     "measured_dofs": dofs,
                                                     "frf_reference_dof": reference_dof_name(setup),
                                                     "frf_reference_row": setup.drive_row,
                                                     **({"updated_reference_row": setup.update_drive_row}
                                                        if setup.drive_off_sensors else {}),
                                                     "frf_kind": "receptance"},
         "layout": {**setup.test.to_dict(), "modes_idx": setup.modes_idx.tolist(),
                    "measured_x_m": sorted(setup.test.sensors_x_m), "truth_elements": setup.n_elements,
                    "updating": update_statement(setup)},
         "section_layout": vars(setup.layout),
         "preset": {**vars(setup.preset), "mass_per_length_kg_m": setup.preset.mass_per_length_kg_m}}
    if rebuild:  # the shards of this config and seed that verify are adopted, the rest regenerated
        m, _ = recover(root, m)
        print(f"{root / 'manifest.json'}: truncated or not JSON; rebuilt from {len(m['shards'])} shard(s) that "
              f"verify", file=sys.stderr)
    write_manifest(root, m)
    return m


def _truncated_manifest(root: Path) -> bool:
    """True when ``manifest.json`` is not a JSON document (a write cut short); other damage is refused elsewhere."""
    try:
        json.loads((root / "manifest.json").read_bytes())
    except (ValueError, UnicodeDecodeError):
        return True
    except OSError:
        return False
    return False


#: Temporary files of this package's writers beside a dataset's top-level files.
_TEMPORARY_PREFIXES = (".manifest.json.", ".omega_rad_s.npy.", ".samples.parquet.", f"{LOCK_NAME}.")


def _remove_stale_temporaries(root: Path) -> None:
    """Remove the temporary files an interrupted run left (called under the writer's lock)."""
    if not root.is_dir():
        return
    for p in root.iterdir():
        if p.name.endswith(".tmp") and p.name.startswith(_TEMPORARY_PREFIXES) and p.is_file():
            p.unlink(missing_ok=True)


def _finalized(root: Path, manifest: dict) -> bool:
    """True when a complete manifest's samples.parquet is on disk as recorded (nothing to rewrite)."""
    want = manifest.get("checksums", {}).get("samples.parquet")
    if not manifest.get("complete") or want is None:
        return False
    try:
        return file_sha256(root / "samples.parquet") == want
    except OSError:
        return False


def generate(root, cfg: dict, *, n: int, seed: int = 0, workers: int = 1, scheduler: str | None = None,
             progress: bool = True, max_new_shards: int | None = None) -> dict:
    """Generate (or resume) a dataset; returns the manifest.

    Parameters
    ----------
    root : path
    cfg : dict          validated configuration (see :mod:`datagen.config`)
    n : int             number of samples
    seed : int
    workers : int       local processes (1 = in this process)
    scheduler : str     Dask scheduler address (``tcp://host:8786``); overrides ``workers``
    progress : bool     tqdm progress bar on stderr (when it is a terminal)
    max_new_shards : int, optional
        Stop after writing this many new shards (leaves a resumable, incomplete dataset).
    """
    cfg = validate(cfg)
    check_arguments(cfg, n, seed, workers, root)
    root = Path(root)
    client = connect(scheduler) if scheduler else None
    created = not root.exists()
    try:
        with _writer_lock(root):
            return _generate(root, cfg, n, seed, workers, client, progress, max_new_shards)
    except LockedError:
        raise
    except BeamDamageError:
        if created:  # a run refused or failed before its first shard leaves nothing behind
            shutil.rmtree(root, ignore_errors=True)
        raise
    finally:
        if client is not None:
            client.close()


@contextlib.contextmanager
def _writer_lock(root: Path):
    """:func:`datagen.lock.dataset_lock` of ``root``; none in a directory this user cannot write (a complete
    dataset is then only verified, and any write it would need fails with its own one-line error)."""
    root.mkdir(parents=True, exist_ok=True)
    lock = dataset_lock(root)
    try:
        lock.__enter__()
    except OSError as exc:
        if exc.errno in (errno.EACCES, errno.EROFS, errno.EPERM) and (root / "manifest.json").exists():
            yield None
            return
        raise
    with contextlib.ExitStack() as stack:
        stack.push(lock)
        yield


def _generate(root, cfg, n, seed, workers, client, progress, max_new_shards) -> dict:
    manifest = open_or_create(root, cfg, seed, n)
    done = {e["index"] for e in manifest["shards"]}
    todo = [s for s in shard_plan(n, cfg["output"]["shard_size"]) if s[0] not in done]
    if max_new_shards is not None:
        todo = todo[:max_new_shards]
    cfg_json = json.dumps(cfg, sort_keys=True)
    from tqdm import tqdm

    bar = tqdm(total=n, initial=sum(e["n_samples"] for e in manifest["shards"]), unit="sample",
               disable=None if progress else True, file=None, desc="generate")  # None: only on a terminal

    store = (get_setup(cfg).omega_rad_s, np.dtype(cfg["output"]["frf_dtype"])) if cfg["output"]["store_frf"] \
        else (None, None)

    identity = manifest.get("identity")

    def record(index, table, arrays):
        entry = write_shard(root, index, table, arrays, *store, identity=identity)
        manifest["shards"] = sorted(manifest["shards"] + [entry], key=lambda e: e["index"])
        write_manifest(root, manifest)
        bar.update(entry["n_samples"])

    try:
        if client is not None:
            from distributed import as_completed as d_as_completed

            futs = {client.submit(compute_shard, cfg_json, seed, i, f, k, pure=False): i for i, f, k in todo}
            for fut in d_as_completed(futs):
                table, arrays = fut.result()
                record(futs[fut], table, arrays)
                fut.release()
        else:
            run_warm_pool(compute_shard, [(i, (cfg_json, seed, i, f, k)) for i, f, k in todo], workers,
                          lambda i, shard: record(i, *shard))
    finally:
        bar.close()
    if len(manifest["shards"]) == manifest["n_shards"] and not _finalized(root, manifest):
        manifest = finalize(root, manifest)
    return manifest
