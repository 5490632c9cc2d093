"""skin.export: a session's frames as a LeRobot v3 dataset. Read back three ways (pyarrow, HF
datasets, Ray Data) the readings are the log's frames bit for bit; meta/ is what LeRobot 0.6
reads (its keys, types and paths, and its own way of loading the frames with the features)."""

import json

import numpy as np
import pytest

import skin
from conftest import FIXTURES, run_skin

LOG = FIXTURES / "session" / "session.candump.log"
CONFIG = FIXTURES / "session" / "run.toml"


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    out = tmp_path_factory.mktemp("export") / "dataset"
    summary = skin.export([LOG], CONFIG, out)
    return out, summary


@pytest.fixture(scope="module")
def source():
    """The log's frames as `skin.read_log` assembles them, per link in the dataset's column
    order (the info's taxel ids), float32."""
    layout = skin.read_layout(FIXTURES / "forearm" / "layout.json")
    busmap = skin.BusMap.read(FIXTURES / "forearm" / "busmap.toml")
    frames = list(skin.read_log(LOG, busmap, layout))
    return layout, frames


def expected(dataset, source):
    out, _ = dataset
    layout, frames = source
    info = json.loads((out / "meta" / "info.json").read_text())
    want = {}
    for k, link in enumerate(info["skin"]["links"]):
        ids = [str(int(i)) for i in layout[link["name"]].ids]
        column = [ids.index(t) for t in link["taxels"]]
        want[link["feature"]] = np.stack([np.asarray(f.values[k], np.float32)[column] for f in frames])
    return want


def bits(a):
    return np.ascontiguousarray(a, dtype=np.float32).view(np.uint32)


def test_the_summary_counts_every_frame(dataset, source):
    _, summary = dataset
    _, frames = source
    assert (summary["episodes"], summary["frames"], summary["fps"]) == (1, len(frames), 20)
    assert summary["added"][0]["source"].endswith("session.candump.log")
    assert summary["failed"] == []


def test_pyarrow_reads_the_frames_bit_for_bit(dataset, source):
    import pyarrow.parquet as pq

    out, _ = dataset
    table = pq.read_table(out / "data" / "chunk-000" / "file-000.parquet")
    for feature, want in expected(dataset, source).items():
        col = table.column(feature).combine_chunks()
        got = col.flatten().to_numpy().reshape(len(col), -1)
        assert np.array_equal(bits(got), bits(want)), feature
    assert table.column("frame_index").to_pylist() == list(range(table.num_rows))
    times = np.array([f.time_us for f in source[1]])
    assert table.column("time_us").to_pylist() == times.tolist()


def test_hf_datasets_reads_the_frames_bit_for_bit(dataset, source, tmp_path, monkeypatch):
    monkeypatch.setenv("HF_DATASETS_OFFLINE", "1")
    monkeypatch.setenv("HF_HUB_OFFLINE", "1")
    datasets = pytest.importorskip("datasets")
    out, _ = dataset
    ds = datasets.load_dataset(
        "parquet", data_files=str(out / "data" / "*" / "*.parquet"), split="train", cache_dir=str(tmp_path)
    ).with_format("numpy")
    for feature, want in expected(dataset, source).items():
        assert np.array_equal(bits(np.stack(ds[feature])), bits(want)), feature


def test_ray_data_reads_the_frames_bit_for_bit(dataset, source, ray_local):
    import pyarrow as pa

    out, _ = dataset
    ds = ray_local.data.read_parquet(str(out / "data"))
    table = pa.concat_tables(ray_local.get(ds.to_arrow_refs())).sort_by("index")
    for feature, want in expected(dataset, source).items():
        col = table.column(feature).combine_chunks()
        assert np.array_equal(bits(col.flatten().to_numpy().reshape(len(col), -1)), bits(want)), feature


# LeRobot v3's metadata, pinned from lerobot's src/lerobot/datasets/utils.py
# (create_empty_dataset_info, DEFAULT_FEATURES, the paths) and the columns its
# lerobot_dataset.py writes to meta/episodes, as LeRobot 0.6 has them: lerobot itself (with
# PyTorch) is not installed here.
LEROBOT_INFO = {
    "codebase_version": str,
    "robot_type": (str, type(None)),
    "total_episodes": int,
    "total_frames": int,
    "total_tasks": int,
    "chunks_size": int,
    "data_files_size_in_mb": int,
    "video_files_size_in_mb": int,
    "fps": int,
    "splits": dict,
    "data_path": str,
    "video_path": (str, type(None)),
    "features": dict,
}
LEROBOT_DEFAULT_FEATURES = {
    "timestamp": {"dtype": "float32", "shape": [1], "names": None},
    "frame_index": {"dtype": "int64", "shape": [1], "names": None},
    "episode_index": {"dtype": "int64", "shape": [1], "names": None},
    "index": {"dtype": "int64", "shape": [1], "names": None},
    "task_index": {"dtype": "int64", "shape": [1], "names": None},
}
LEROBOT_DATA_PATH = "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
LEROBOT_EPISODE_COLUMNS = {
    "episode_index",
    "tasks",
    "length",
    "data/chunk_index",
    "data/file_index",
    "dataset_from_index",
    "dataset_to_index",
    "meta/episodes/chunk_index",
    "meta/episodes/file_index",
}


def lerobot_hf_features(features):
    """lerobot's get_hf_features_from_features: the HF features it loads the frames with."""
    import datasets

    hf = {}
    for key, ft in features.items():
        shape = tuple(ft["shape"])
        if shape == (1,):
            hf[key] = datasets.Value(dtype=ft["dtype"])
        elif len(shape) == 1:
            hf[key] = datasets.Sequence(length=shape[0], feature=datasets.Value(dtype=ft["dtype"]))
        else:
            raise AssertionError(f"{key}: shape {shape} is not one skin writes")
    return datasets.Features(hf)


def test_info_json_is_lerobot_v3(dataset):
    out, summary = dataset
    info = json.loads((out / "meta" / "info.json").read_text())
    for key, kind in LEROBOT_INFO.items():
        assert isinstance(info[key], kind), (key, info[key])
    assert info["codebase_version"] == "v3.0"
    assert info["data_path"] == LEROBOT_DATA_PATH
    assert info["splits"] == {"train": "0:1"}
    assert (info["total_episodes"], info["total_frames"], info["total_tasks"]) == (1, summary["frames"], 1)
    for name, ft in LEROBOT_DEFAULT_FEATURES.items():
        assert info["features"][name] == ft, name
    for name, ft in info["features"].items():
        assert "/" not in name
        assert set(ft) >= {"dtype", "shape", "names"} and all(isinstance(n, int) for n in ft["shape"])
    tactile = {k: v for k, v in info["features"].items() if k.startswith("observation.tactile.")}
    assert list(tactile) == ["observation.tactile.forearm"]
    link = info["skin"]["links"][0]
    assert tactile["observation.tactile.forearm"]["names"] == link["taxels"]
    assert len(link["positions"]) == len(link["normals"]) == tactile["observation.tactile.forearm"]["shape"][0]


def test_meta_is_found_and_loaded_as_lerobot_does(dataset, tmp_path, monkeypatch):
    import pandas as pd
    import pyarrow.parquet as pq

    monkeypatch.setenv("HF_DATASETS_OFFLINE", "1")
    datasets = pytest.importorskip("datasets")
    out, summary = dataset
    info = json.loads((out / "meta" / "info.json").read_text())
    tasks = pd.read_parquet(out / "meta" / "tasks.parquet")
    assert tasks.index.name == "task" and list(tasks.index) == ["skin session"]
    assert tasks.loc["skin session", "task_index"] == 0
    episodes = pq.read_table(out / "meta" / "episodes" / "chunk-000" / "file-000.parquet").to_pylist()
    assert LEROBOT_EPISODE_COLUMNS <= set(episodes[0])
    ep = episodes[0]
    assert (ep["episode_index"], ep["length"], ep["tasks"]) == (0, summary["frames"], ["skin session"])
    assert (ep["dataset_from_index"], ep["dataset_to_index"]) == (0, summary["frames"])
    assert len(ep["skin/baseline/forearm"]) == info["features"]["observation.tactile.forearm"]["shape"][0]
    # The frames file LeRobot finds from the episode's row, loaded with LeRobot's features.
    path = out / info["data_path"].format(chunk_index=ep["data/chunk_index"], file_index=ep["data/file_index"])
    frames = datasets.Dataset.from_parquet(
        str(path), features=lerobot_hf_features(info["features"]), cache_dir=str(tmp_path)
    )
    assert len(frames) == summary["frames"]
    assert frames.features["observation.tactile.forearm"].length == info["features"]["observation.tactile.forearm"]["shape"][0]


def test_the_command_line_writes_the_same_dataset(dataset, tmp_path):
    out, _ = dataset
    cli = tmp_path / "cli"
    done = run_skin("export", LOG, "--config", CONFIG, "-o", cli)
    assert "1 episode(s)" in done.stdout
    for rel in ("data/chunk-000/file-000.parquet", "events/chunk-000/file-000.parquet", "meta/info.json"):
        assert (cli / rel).read_bytes() == (out / rel).read_bytes(), rel


def test_an_existing_dataset_is_refused_unless_appended_to(dataset, tmp_path):
    out, summary = dataset
    copy = tmp_path / "copy"
    skin.export([LOG], CONFIG, copy)
    with pytest.raises(skin.InputError, match="holds a dataset already"):
        skin.export([LOG], CONFIG, copy)
    s = skin.export([LOG], CONFIG, copy, append=True)
    assert (s["episodes"], s["frames"]) == (2, 2 * summary["frames"])
    assert [a["episode"] for a in s["added"]] == [1]


def test_events_are_the_sessions_events(dataset, builtin_session_events):
    import pyarrow.parquet as pq

    out, _ = dataset
    events = pq.read_table(out / "events" / "chunk-000" / "file-000.parquet").to_pylist()
    assert [e["kind"] for e in events] == [e.kind for e in builtin_session_events]
    # Each row holds its event whole: the line `events.jsonl` has, as `Event.to_dict()` gives it.
    assert [json.loads(e["json"]) for e in events] == [e.to_dict() for e in builtin_session_events]
    frames = [e["frame_index"] for e in events]
    assert frames == sorted(frames)
    # An incomplete frame's event is on that frame.
    complete = pq.read_table(out / "data" / "chunk-000" / "file-000.parquet", columns=["complete"]).column("complete")
    for e in events:
        if e["kind"] == "incomplete":
            assert complete[e["frame_index"]].as_py() is False, e
