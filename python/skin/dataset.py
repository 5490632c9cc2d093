"""`SynthDataset`: the output folder of `skin synth` as a map-style dataset that a PyTorch
`DataLoader` takes (torch is not needed to use it)."""

import os
from typing import Any, Callable, Dict, List, Optional

from ._skin import Dataset as _Dataset


class SynthDataset:
    """The samples of a `skin synth` folder (``labels.csv``, ``images/``, ``masks/``).

    ``dataset[i]`` is a dict: ``image`` (rows, cols) uint8, ``label`` 1 for a hand and 0 for
    anything else, ``mask`` (rows, cols) uint8 part labels (0 background, then thumb, index,
    middle, ring, pinkie, palm), ``subject``, ``kind``. ``transform``, if given, is applied to
    that dict (to make tensors, normalise, augment). ``subjects`` keeps only the samples of
    those subjects (to split train and test by subject, as the thesis does).

    The folder is read as ``skin eval`` reads it: a file name in ``labels.csv`` that leaves the
    folder (an absolute path, ``..``) is an ``InputError`` naming the line, and so is, when the
    sample is read, a file that is a symbolic link out of the folder.
    """

    def __init__(
        self,
        root: "os.PathLike[str] | str",
        transform: Optional[Callable[[Dict[str, Any]], Any]] = None,
        subjects: Optional[List[int]] = None,
    ) -> None:
        self.root = os.fspath(root)
        self.transform = transform
        self._data = _Dataset(self.root)
        keep = None if subjects is None else set(subjects)
        self.entries: List[Dict[str, Any]] = []
        # Row of labels.csv (among its samples) of each entry kept.
        self._rows: List[int] = []
        for row, (file, hand, kind, subject, partial, tips) in enumerate(self._data.entries):
            if keep is not None and subject not in keep:
                continue
            self._rows.append(row)
            self.entries.append(
                {
                    "file": file,
                    "label": 1 if hand else 0,
                    "kind": kind,
                    "subject": subject,
                    "partial": partial,
                    "fingertips": tips,
                }
            )

    def __len__(self) -> int:
        return len(self.entries)

    def __getitem__(self, i: int) -> Any:
        if not -len(self) <= i < len(self):
            raise IndexError(f"sample {i}: the dataset has {len(self)}")
        e = self.entries[i]
        row = self._rows[i]
        # Masks are written for hands only: anything else presses no hand part.
        image, mask = self._data.image(row), self._data.mask(row)
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
