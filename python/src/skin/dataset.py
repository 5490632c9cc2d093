"""`SynthDataset`: the output folder of `skin synth` as a map-style dataset that a PyTorch
`DataLoader` takes (torch is not needed to use it)."""

import csv
import os
from typing import Any, Callable, Dict, List, Optional

import numpy as np

from ._errors import InputError
from ._skin import read_grey

_HEADER = ["file", "class", "kind", "subject", "partial", "fingertips"]


class SynthDataset:
    """The samples of a `skin synth` folder (``labels.csv``, ``images/``, ``masks/``).

    ``dataset[i]`` is a dict: ``image`` (rows, cols) uint8, ``label`` 1 for a hand and 0 for
    anything else, ``mask`` (rows, cols) uint8 part labels (0 background, then thumb, index,
    middle, ring, pinkie, palm), ``subject``, ``kind``. ``transform``, if given, is applied to
    that dict (to make tensors, normalise, augment). ``subjects`` keeps only the samples of
    those subjects (to split train and test by subject, as the thesis does).
    """

    def __init__(
        self,
        root: "os.PathLike[str] | str",
        transform: Optional[Callable[[Dict[str, Any]], Any]] = None,
        subjects: Optional[List[int]] = None,
    ) -> None:
        self.root = os.fspath(root)
        self.transform = transform
        labels = os.path.join(self.root, "labels.csv")
        try:
            with open(labels, newline="", encoding="utf-8-sig") as f:
                rows = list(csv.reader(f))
        except OSError as e:
            raise InputError(f"{labels}: cannot read ({e.strerror}): is {self.root} a `skin synth` folder?") from None
        if not rows or [c.strip() for c in rows[0]] != _HEADER:
            found = ",".join(rows[0]) if rows else ""
            raise InputError(f"{labels}: line 1: expected the header `{','.join(_HEADER)}`, found `{found}`")
        keep = None if subjects is None else set(subjects)
        self.entries: List[Dict[str, Any]] = []
        for line, row in enumerate(rows[1:], start=2):
            if not row:
                continue
            if len(row) != len(_HEADER):
                raise InputError(f"{labels}: line {line}: {len(row)} fields, expected {len(_HEADER)}")
            file, cls, kind, subject, partial, tips = row
            if cls not in ("hand", "non_hand"):
                raise InputError(f"{labels}: line {line}: class {cls!r}: expected hand or non_hand")
            try:
                subject_number = int(subject)
            except ValueError:
                raise InputError(f"{labels}: line {line}: subject {subject!r} is not a number") from None
            if keep is not None and subject_number not in keep:
                continue
            self.entries.append(
                {
                    "file": file,
                    "label": 1 if cls == "hand" else 0,
                    "kind": kind,
                    "subject": subject_number,
                    "partial": partial == "1",
                    "fingertips": tips == "1",
                }
            )

    def __len__(self) -> int:
        return len(self.entries)

    def __getitem__(self, i: int) -> Any:
        if not -len(self) <= i < len(self):
            raise IndexError(f"sample {i}: the dataset has {len(self)}")
        e = self.entries[i]
        image = read_grey(os.path.join(self.root, "images", e["file"]))
        # Masks are written for hands only: anything else presses no hand part.
        mask = read_grey(os.path.join(self.root, "masks", e["file"])) if e["label"] else np.zeros_like(image)
        sample = {
            "image": image,
            "mask": mask,
            "label": e["label"],
            "subject": e["subject"],
            "kind": e["kind"],
        }
        return self.transform(sample) if self.transform is not None else sample

    def __repr__(self) -> str:
        hands = sum(e["label"] for e in self.entries)
        return f"SynthDataset({self.root!r}, {len(self)} samples, {hands} hands)"
