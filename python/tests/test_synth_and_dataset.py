"""Synthetic labelled contacts straight to arrays, equal to `skin synth`; its folder as a dataset
a DataLoader takes."""

import numpy as np
import pytest

import skin
from conftest import FIXTURES, run_skin

LAYOUT = FIXTURES / "forearm" / "layout.json"


@pytest.fixture(scope="module")
def synth_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("synth") / "ds"
    run_skin("synth", "--layout", LAYOUT, "--count", "24", "--subjects", "3", "--seed", "5", "-o", out)
    return out


def test_synthesize_equals_skin_synth(synth_dir):
    tmap = skin.read_map(LAYOUT)
    s = skin.synthesize(tmap, 24, seed=5, subjects=3)
    assert s["images"].shape == (24, 68, 100) and s["images"].dtype == np.uint8
    assert s["masks"].shape == (24, 68, 100)
    assert s["pressures"].shape == (24, len(tmap)) and s["taxel_parts"].shape == (24, len(tmap))
    ds = skin.SynthDataset(synth_dir)
    assert len(ds) == 24
    for i in range(24):
        sample = ds[i]
        np.testing.assert_array_equal(sample["image"], s["images"][i])
        assert sample["label"] == int(s["hand"][i])
        assert sample["subject"] == s["subject"][i] and sample["kind"] == s["kind"][i]
        if s["hand"][i]:
            np.testing.assert_array_equal(sample["mask"], s["masks"][i])
    assert sorted(set(s["subject"].tolist())) == [0, 1, 2]
    # Hands press with their parts; nothing else does.
    assert (s["masks"][~s["hand"]] == 0).all() and (s["masks"][s["hand"]].max(axis=(1, 2)) > 0).all()


def test_synthesize_with_degraded_maps_and_labels_as_imaged_equals_skin_synth(tmp_path, synth_dir):
    tmap = skin.read_map(LAYOUT)
    options = ["--remove-up-to", "0.7", "--thinned-share", "0.4", "--blind-spots", "4", "--blind-share", "0.4", "--mask-labels", "as-imaged"]
    out = tmp_path / "degraded"
    run_skin("synth", "--layout", LAYOUT, "--count", "24", "--subjects", "3", "--seed", "5", *options, "-o", out)
    s = skin.synthesize(tmap, 24, seed=5, subjects=3, remove_up_to=0.7, thinned_share=0.4, blind_spots=4, blind_share=0.4, mask_labels="as-imaged")
    ds = skin.SynthDataset(out)
    for i in range(24):
        sample = ds[i]
        np.testing.assert_array_equal(sample["image"], s["images"][i])
        if s["hand"][i]:
            np.testing.assert_array_equal(sample["mask"], s["masks"][i])
    # Each sample through one map at most: thinned (up to 70% removed), blind spots, or whole.
    removed, dead = s["removed"], s["dead"]
    assert removed.shape == dead.shape == (24,) and removed.dtype == np.float64
    assert ((removed > 0) & (dead > 0)).sum() == 0
    assert 0 < (removed > 0).sum() < 24 and 0 < (dead > 0).sum() < 24
    # A removal rounds to whole taxels: at most half a taxel over the fraction asked for.
    assert removed.max() <= 0.7 + 0.5 / len(tmap) and dead.max() < 1
    # The same contacts as without the options, read by every taxel; a whole sample is imaged as before.
    plain = skin.synthesize(tmap, 24, seed=5, subjects=3)
    np.testing.assert_array_equal(plain["pressures"], s["pressures"])
    assert (plain["removed"] == 0).all() and (plain["dead"] == 0).all()
    whole = (removed == 0) & (dead == 0)
    np.testing.assert_array_equal(plain["images"][whole], s["images"][whole])


def test_dataset_split_by_subject_and_transform(synth_dir):
    train = skin.SynthDataset(synth_dir, subjects=[0, 1])
    test = skin.SynthDataset(synth_dir, subjects=[2], transform=lambda d: (d["image"].astype(np.float32) / 255, d["label"]))
    assert len(train) + len(test) == 24
    x, y = test[0]
    assert x.dtype == np.float32 and x.max() <= 1
    with open(synth_dir / "labels.csv") as f:
        rows = [line.split(",") for line in f.read().splitlines()[1:]]
    subject2 = [r for r in rows if r[3] == "2"]
    assert [test[i][1] for i in range(len(test))] == [int(r[1] == "hand") for r in subject2]
    assert 0 < sum(int(r[1] == "hand") for r in rows) < len(rows)
    with pytest.raises(IndexError):
        test[len(test)]


def test_a_dataloader_takes_it(synth_dir):
    torch = pytest.importorskip("torch", reason="PyTorch is not installed (CI does not install it: a 5 GB download)")
    loader = torch.utils.data.DataLoader(skin.SynthDataset(synth_dir), batch_size=8)
    batch = next(iter(loader))
    assert batch["image"].shape == (8, 68, 100) and batch["label"].shape == (8,)


def test_not_a_dataset_folder_is_named(tmp_path):
    with pytest.raises(skin.InputError, match="labels.csv"):
        skin.SynthDataset(tmp_path)
    (tmp_path / "labels.csv").write_text("name,label\n")
    with pytest.raises(skin.InputError, match="labels.csv:1: expected the header"):
        skin.SynthDataset(tmp_path)


def test_a_file_name_that_leaves_the_dataset_folder_is_refused(tmp_path, synth_dir):
    import shutil

    ds = tmp_path / "ds"
    shutil.copytree(synth_dir, ds)
    labels = (ds / "labels.csv").read_text().splitlines()
    first = labels[1].split(",")
    for name in ["../../../../etc/passwd", "/etc/passwd", "images/../../labels.csv"]:
        (ds / "labels.csv").write_text("\n".join([labels[0], labels[1], ",".join([name, *first[1:]])]) + "\n")
        with pytest.raises(skin.InputError, match=rf"labels.csv:3: file `{name}` .*(absolute|\.\.)"):
            skin.SynthDataset(ds)
    # A name that stays inside (a subfolder) is read.
    (ds / "images" / "sub").mkdir()
    shutil.copy(ds / "images" / first[0], ds / "images" / "sub" / first[0])
    (ds / "masks" / "sub").mkdir()
    if (ds / "masks" / first[0]).exists():
        shutil.copy(ds / "masks" / first[0], ds / "masks" / "sub" / first[0])
    (ds / "labels.csv").write_text("\n".join([labels[0], ",".join(["sub/" + first[0], *first[1:]])]) + "\n")
    np.testing.assert_array_equal(skin.SynthDataset(ds)[0]["image"], skin.SynthDataset(synth_dir)[0]["image"])
    # A file that is a link out of the folder is refused when it is read, naming its line.
    outside = tmp_path / "secret.png"
    shutil.copy(ds / "images" / first[0], outside)
    (ds / "images" / "link.png").symlink_to(outside)
    (ds / "labels.csv").write_text("\n".join([labels[0], labels[1], ",".join(["link.png", "non_hand", *first[2:]])]) + "\n")
    data = skin.SynthDataset(ds)
    assert data[0]["image"].shape == (68, 100)
    with pytest.raises(skin.InputError, match=r"labels.csv:3: file `link.png`: .* is a link to .*secret.png, outside the dataset's folder"):
        data[1]
    # A link inside the folder is followed.
    (ds / "images" / "inside.png").symlink_to(ds / "images" / first[0])
    (ds / "labels.csv").write_text("\n".join([labels[0], ",".join(["inside.png", "non_hand", *first[2:]])]) + "\n")
    np.testing.assert_array_equal(skin.SynthDataset(ds)[0]["image"], skin.SynthDataset(synth_dir)[0]["image"])
