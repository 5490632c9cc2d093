"""skin at scale on Ray Data: thousands of logs made into datasets on as many machines as a Ray
cluster has (``pip install ./python[ray]``).

The recipe (README, "At scale")::

    import ray, skin.ray
    ray.init()                                   # or ray.init(address="ray://head:10001")
    report = (
        ray.data.read_binary_files(logs, include_paths=True)
        .map_batches(skin.ray.Convert("run.toml", "fleet"), batch_size=1)
    )
    report.write_parquet("fleet-report")         # a row per input: converted, skipped, failed

``Convert`` writes each input as a dataset of its own, ``OUT/<sha256>/`` (the LeRobot v3
layout ``skin export`` writes, one episode), named by the SHA-256 of the input's bytes: a rerun
skips every input whose dataset is there, and a dataset appears whole or not at all, so a run
killed midway leaves nothing that looks finished and the next one does only the rest. The
frames are written by skin, not by Ray's ``write_parquet``, because Ray writes its files in
place: a worker killed mid-write leaves a file that looks like any other.

``Frames`` and ``Touches`` give the same conversion as rows, for a pipeline that goes on in Ray
(a training set, statistics): the per-frame table (``observation.tactile.<link>`` lists of raw
counts) and the per-touch table (each event of each touch), each row with its input's
``source`` and ``sha256``. ``synthesize`` makes a synthetic dataset in shards, each a function
of the seed and its sample indices alone: the same bytes whatever the number of workers.

Every function here releases the GIL while skin works (the conversion is skin's Rust session).
"""

import os
import tempfile
from typing import Any, Dict, Iterable, List, Optional, Sequence, Union

import numpy as np

from . import _skin
from ._errors import SkinError

_Path = Union[str, "os.PathLike[str]"]

# The report's columns, in order (one row per input).
REPORT_COLUMNS = ("path", "sha256", "status", "frames", "events", "dataset", "error")


def _sha256(data: bytes) -> str:
    import hashlib

    return hashlib.sha256(data).hexdigest()


def finished(dataset: _Path) -> bool:
    """Whether ``dataset`` is a whole dataset of skin's: its ``meta/info.json`` is there and no
    commit of it was cut short (no ``INCOMPLETE`` marker)."""
    root = os.fspath(dataset)
    return os.path.isfile(os.path.join(root, "meta", "info.json")) and not os.path.exists(
        os.path.join(root, "INCOMPLETE")
    )


def _rows(batch: Any) -> List[tuple]:
    """The (path, bytes) of each row of a batch: ``read_binary_files(..., include_paths=True)``
    rows (``bytes`` and ``path``), or rows of paths alone (``path``: each worker reads its own
    file, from storage every node sees), as a dict of arrays, a pandas frame or a pyarrow table.
    ``bytes`` is None for a path alone."""
    if hasattr(batch, "to_pydict"):
        batch = batch.to_pydict()
    elif hasattr(batch, "to_dict") and not isinstance(batch, dict):
        batch = {k: list(v) for k, v in batch.to_dict("list").items()}
    if "bytes" not in batch and "path" not in batch:
        raise SkinError("a batch of skin.ray needs a 'bytes' column (ray.data.read_binary_files) or a 'path' column")
    if "bytes" not in batch:
        return [(str(p), None) for p in batch["path"]]
    data = list(batch["bytes"])
    paths = list(batch["path"]) if "path" in batch else [f"input-{i}" for i in range(len(data))]
    return [(str(p), bytes(d)) for p, d in zip(paths, data)]


def _file_sha256(path: str) -> str:
    import hashlib

    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


class Convert:
    """A ``map_batches`` callable: each input of the batch (``bytes``, and ``path`` with
    ``include_paths=True``; or ``path`` alone, read by the worker) exported to
    ``OUT/<sha256>/`` as ``skin export`` exports it, through
    a session of ``config`` (run.toml; its paths must be readable on every worker). Returns one
    row per input (``REPORT_COLUMNS``): ``status`` is ``converted``, ``skipped`` (its dataset was
    there whole) or ``failed`` (``error`` names the file and what is wrong: a corrupt log among
    many fails alone, leaving nothing behind).
    """

    def __init__(
        self,
        config: _Path,
        out: _Path,
        *,
        task: str = "skin session",
        robot_type: Optional[str] = None,
        fps: Optional[int] = None,
    ) -> None:
        self.config = os.path.abspath(os.fspath(config))
        self.out = os.path.abspath(os.fspath(out))
        self.options: Dict[str, Any] = {"task": task, "robot_type": robot_type, "fps": fps}

    def _check_out(self) -> None:
        """OUT belongs to one configuration: its datasets are skipped by the inputs' hashes
        alone, so a rerun with another run.toml (or task, or fps) must not find them there. The
        first call records the configuration's SHA-256 and the options in ``OUT/.skin-convert.json``;
        a call with others is refused."""
        import json

        with open(self.config, "rb") as f:
            mine = {"config_sha256": _sha256(f.read()), **{k: v for k, v in self.options.items()}}
        os.makedirs(self.out, exist_ok=True)
        path = os.path.join(self.out, ".skin-convert.json")
        try:
            fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
        except FileExistsError:
            with open(path, encoding="utf-8") as f:
                theirs = json.load(f)
            if theirs != mine:
                raise SkinError(
                    f"{self.out} holds datasets of another configuration or options ({theirs}, "
                    f"not {mine}): convert into another folder"
                ) from None
            return
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            json.dump(mine, f)

    def __call__(self, batch: Any) -> Dict[str, np.ndarray]:
        self._check_out()
        rows: Dict[str, List[Any]] = {k: [] for k in REPORT_COLUMNS}
        for path, data in _rows(batch):
            try:
                sha = _sha256(data) if data is not None else _file_sha256(path)
            except OSError as e:
                sha = ""
                status, error, frames, events, dataset = "failed", f"{path}: {e.strerror}", 0, 0, ""
                for k, v in zip(REPORT_COLUMNS, (path, sha, status, frames, events, dataset, error)):
                    rows[k].append(v)
                continue
            dataset = os.path.join(self.out, sha)
            frames = events = 0
            error = ""
            if finished(dataset):
                status = "skipped"
            else:
                try:
                    if data is None:
                        s = _skin.export([path], self.config, dataset, **self.options)
                        if s["failed"]:
                            raise SkinError(s["failed"][0][1])
                    else:
                        s = _skin.export_bytes(path, data, self.config, dataset, **self.options)
                    status = "converted"
                    frames = int(s["frames"])
                    events = int(s["added"][0]["events"])
                except SkinError as e:
                    status, error = "failed", str(e)
            for k, v in zip(REPORT_COLUMNS, (path, sha, status, frames, events, dataset, error)):
                rows[k].append(v)
        return {
            k: np.array(v, dtype=np.int64 if k in ("frames", "events") else object)
            for k, v in rows.items()
        }


class _Tables:
    """What ``Frames`` and ``Touches`` share: each input exported to a folder of its own in a
    temporary directory, then read back with pyarrow."""

    table = ""

    def __init__(self, config: _Path, *, task: str = "skin session", fps: Optional[int] = None) -> None:
        self.config = os.path.abspath(os.fspath(config))
        self.options: Dict[str, Any] = {"task": task, "fps": fps}

    def __call__(self, batch: Any) -> Any:
        import pyarrow as pa
        import pyarrow.parquet as pq

        tables = []
        for path, data in _rows(batch):
            with tempfile.TemporaryDirectory(prefix="skin-ray-") as tmp:
                out = os.path.join(tmp, "dataset")
                if data is None:
                    s = _skin.export([path], self.config, out, **self.options)
                else:
                    s = _skin.export_bytes(path, data, self.config, out, **self.options)
                t = pq.read_table(os.path.join(out, self.table))
            t = t.append_column("source", pa.array([path] * t.num_rows, pa.string()))
            t = t.append_column("sha256", pa.array([s["added"][0]["sha256"]] * t.num_rows, pa.string()))
            tables.append(t)
        if not tables:
            return pa.table({})
        return pa.concat_tables(tables)


class Frames(_Tables):
    """A ``map_batches`` callable: the per-frame table of each input (one row per frame:
    ``timestamp``, ``frame_index``, ``time_us``, ``cycle``, ``complete``, and
    ``observation.tactile.<link>``, the link's raw counts as float32 lists in the bus map's
    order, a recording's in the layout's), with ``source`` and ``sha256``; each input is an
    episode of its own, so ``episode_index`` is 0 and ``frame_index`` counts from 0 in every
    one (``source`` tells them apart). Raises ``InputError`` naming an input that cannot be
    read (use ``Convert`` to convert many and report the bad ones)."""

    table = "data"


class Touches(_Tables):
    """A ``map_batches`` callable: the events table of each input, with ``source`` and
    ``sha256``: one row per event, ``kind`` (a touch's appeared, classified, released, and the
    session's own: incomplete, gate, tare ...), ``link`` and ``touch`` where the event has
    them, ``timestamp``, ``frame_index``, and the event's whole ``json``. A touch's rows share
    its ``touch``; its ``released`` row sums it up."""

    table = "events"


def report(rows: Iterable[Dict[str, Any]]) -> Dict[str, int]:
    """How many inputs of a ``Convert`` report were converted, skipped and failed."""
    counts = {"converted": 0, "skipped": 0, "failed": 0}
    for r in rows:
        counts[str(r["status"])] += 1
    return counts


class _Shard:
    """One shard of ``synthesize``: samples ``start`` to ``stop - 1`` written to its own file."""

    def __init__(self, layout: str, link: Optional[str], count: int, out: str, options: Dict[str, Any]) -> None:
        self.layout, self.link, self.count, self.out, self.options = layout, link, count, out, options
        self.map: Any = None

    def __call__(self, batch: Dict[str, np.ndarray]) -> Dict[str, np.ndarray]:
        names = [self.write(int(s), int(e)) for s, e in zip(batch["start"], batch["stop"])]
        return {"file": np.array(names, dtype=object)}

    def write(self, start: int, stop: int) -> str:
        import pyarrow as pa
        import pyarrow.parquet as pq

        name = f"shard-{start:09d}-{stop:09d}.parquet"
        path = os.path.join(self.out, name)
        if os.path.exists(path):
            return name
        if self.map is None:
            layout = _skin.read_layout(self.layout)
            self.map = _skin.flatten(layout[self.link] if self.link is not None else layout[0])
        s = _skin.synthesize(self.map, self.count, part=(start, stop), **self.options)
        n = stop - start
        table = pa.table(
            {
                "index": pa.array(np.arange(start, stop, dtype=np.int64)),
                "image": _fixed(s["images"].reshape(n, -1)),
                "mask": _fixed(s["masks"].reshape(n, -1)),
                "hand": pa.array(s["hand"]),
                "kind": pa.array(list(s["kind"]), pa.string()),
                "subject": pa.array(np.asarray(s["subject"], dtype=np.int64)),
                "partial": pa.array(s["partial"]),
                "fingertips": pa.array(s["fingertips"]),
                "pressures": _fixed(s["pressures"]),
                "taxel_parts": _fixed(s["taxel_parts"]),
                "removed": pa.array(s["removed"]),
                "dead": pa.array(s["dead"]),
            },
            metadata={b"skin.image_size": f"{s['images'].shape[1]}x{s['images'].shape[2]}".encode()},
        )
        # Written aside (a hidden name, which pyarrow's and Ray's readers skip) and moved into
        # place: a shard file is whole or absent.
        tmp = os.path.join(self.out, f".{name}.partial-{os.getpid()}")
        pq.write_table(table, tmp)
        os.replace(tmp, path)
        return name


def _fixed(a: np.ndarray) -> Any:
    """Rows of a 2-D array as a fixed-size list column."""
    import pyarrow as pa

    a = np.ascontiguousarray(a)
    return pa.FixedSizeListArray.from_arrays(pa.array(a.reshape(-1)), a.shape[1])


def synthesize(
    layout: _Path,
    count: int,
    out: _Path,
    *,
    link: Optional[str] = None,
    shard_size: int = 1000,
    workers: Optional[int] = None,
    **options: Any,
) -> List[str]:
    """``count`` synthetic samples on ``link`` of ``layout`` (the first link by default), made on
    Ray in shards of ``shard_size``, one Parquet file each in ``out``
    (``shard-SSSSSSSSS-EEEEEEEEE.parquet``: ``index``, ``image`` and ``mask`` flattened rows,
    ``hand``, ``kind``, ``subject``, ``partial``, ``fingertips``, ``pressures``,
    ``taxel_parts``, ``removed``, ``dead``). ``options`` are ``skin.synthesize``'s (``seed``,
    ``subjects``, ``size`` ...). Each sample depends on the seed, its subject and its index
    alone, so the files are the same bytes whatever ``workers`` (tasks at once; default all
    of the cluster's CPUs); a shard already written is kept, so a rerun makes only the missing
    ones (``out/.skin-synthesize.json`` records the set's parameters: a rerun with others is
    refused). Returns the shard files, in order."""
    import ray

    if count < 1 or shard_size < 1:
        raise SkinError(f"synthesize: count ({count}) and shard_size ({shard_size}) must be at least 1")
    import json

    out = os.path.abspath(os.fspath(out))
    os.makedirs(out, exist_ok=True)
    # The shards kept by a rerun must be of the same set: its parameters are recorded once.
    with open(os.fspath(layout), "rb") as f:
        params = {"layout_sha256": _sha256(f.read()), "link": link, "count": count, "shard_size": shard_size,
                  "options": {k: (list(v) if isinstance(v, tuple) else v) for k, v in sorted(options.items())}}
    record = os.path.join(out, ".skin-synthesize.json")
    if os.path.exists(record):
        with open(record, encoding="utf-8") as f:
            theirs = json.load(f)
        if theirs != params:
            raise SkinError(f"{out} holds shards of another set ({theirs}, not {params}): synthesize into another folder")
    else:
        with open(record, "w", encoding="utf-8") as f:
            json.dump(params, f)
    # What a killed worker left: its hidden temporary files (of this folder's shards alone).
    for name in os.listdir(out):
        if name.startswith(".shard-") and ".partial-" in name:
            os.remove(os.path.join(out, name))
    starts = list(range(0, count, shard_size))
    bounds = {"start": np.array(starts), "stop": np.array([min(s + shard_size, count) for s in starts])}
    shard = _Shard(os.path.abspath(os.fspath(layout)), link, count, out, dict(options))
    kwargs: Dict[str, Any] = {"batch_size": 1, "num_cpus": 1}
    if workers is not None:
        kwargs["compute"] = ray.data.TaskPoolStrategy(size=workers)
    ds = ray.data.from_items([{"start": a, "stop": b} for a, b in zip(bounds["start"], bounds["stop"])])
    names = ds.map_batches(shard, **kwargs).take_all()
    return sorted(str(r["file"]) for r in names)


def pending(paths: Sequence[_Path], out: _Path) -> List[str]:
    """The inputs of ``paths`` whose dataset is not yet in ``out`` (by the SHA-256 of their
    bytes, read here): what a rerun of ``Convert`` still has to do, to size it or list it."""
    left = []
    for p in paths:
        sha = _file_sha256(os.fspath(p))
        if not finished(os.path.join(os.fspath(out), sha)):
            left.append(os.fspath(p))
    return left


__all__ = ["Convert", "Frames", "REPORT_COLUMNS", "Touches", "finished", "pending", "report", "synthesize"]
