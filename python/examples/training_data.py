"""Synthetic labelled contacts for training, without files: images, labels and part masks as
arrays; and a `skin synth` folder as a dataset a PyTorch DataLoader takes.

    python python/examples/training_data.py [SKIN]     # from the repository root

SKIN is the `skin` command that writes the folder (default: target/debug/skin, built by
`cargo build -p skin-cli`).
"""

import subprocess
import sys
import tempfile

import numpy as np

import skin

tmap = skin.read_map("fixtures/forearm/layout.json")
data = skin.synthesize(tmap, 200, seed=7)  # the samples `skin synth --count 200 --seed 7` writes
images, hand, masks = data["images"], data["hand"], data["masks"]
print(f"{len(images)} images {images.shape[1:]} uint8: {hand.sum()} hands, {len(hand) - hand.sum()} other contacts")
print(f"hand pixels per part (thumb .. palm): {np.bincount(masks[hand].ravel(), minlength=7)[1:]}")

# For models that must hold up on a damaged skin: the same contacts, some imaged through maps
# with up to 70% of the taxels removed (Test B) or with 1-4 blind spots of up to 40 mm (Test A).
hardy = skin.synthesize(tmap, 200, seed=7, remove_up_to=0.7, blind_spots=4)
print(f"{(hardy['removed'] > 0).sum()} thinned, {(hardy['dead'] > 0).sum()} with blind spots, "
      f"{((hardy['removed'] == 0) & (hardy['dead'] == 0)).sum()} whole")

# The same samples on disk, and read back as a map-style dataset.
with tempfile.TemporaryDirectory() as tmp:
    subprocess.run([sys.argv[1] if len(sys.argv) > 1 else "target/debug/skin", "synth", "--layout", "fixtures/forearm/layout.json",
                    "--count", "40", "--seed", "7", "-o", f"{tmp}/ds"], check=True, capture_output=True)
    train = skin.SynthDataset(f"{tmp}/ds", transform=lambda s: (s["image"][None].astype(np.float32) / 255, s["label"]))
    x, y = train[0]
    print(f"dataset of {len(train)}: sample 0 is {x.shape} float32, label {y}")
    try:
        import torch

        loader = torch.utils.data.DataLoader(train, batch_size=16, shuffle=True)
        xb, yb = next(iter(loader))
        print(f"a DataLoader batch: {tuple(xb.shape)}, labels {yb.tolist()}")
    except ImportError:
        print("(PyTorch not installed: torch.utils.data.DataLoader(train, batch_size=16) takes it as it is)")
