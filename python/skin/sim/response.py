"""From the stress at each taxel to the counts a real skin reads (a run configuration's `[sim]`).

    counts = rest_i +- gain_i * full_scale * s / (s + half_scale) + noise      (+ rising, - falling)

rounded, within 0 and full scale; `s` the stress and `half_scale` (`half_scale_kpa`) in the same
unit, so a taxel of gain 1 reads rest + full_scale / 2 at half_scale, and approaches rest +
gain * full_scale under a load it cannot take (a capacitive cell stiffens). Each taxel's gain is
drawn once uniformly in 1 +- gain_spread and its rest in rest +- rest_spread (a cell's own
sensitivity and offset); noise is Gaussian, drawn every frame. A dead taxel reads its rest, no
noise (a broken cell reads a constant). Falling polarity (iCub: 255 at rest) needs a rest near
full scale. With a bus map, a module named in `missing_modules` stops delivering once the
session has had the complete frames its baseline needs (`[baseline] frames`; a module
missing from the start keeps a session from ever learning one), every module is lost in a frame
with probability `dropout` (with M modules a frame is complete with probability
(1 - dropout)^M), and taxels the buses do not carry are not in the frame: the session reports
all of these as a CAN log's. Everything is drawn from `seed`: the same configuration gives the
same frames.
"""

from __future__ import annotations

from typing import List, Mapping, Optional, Sequence, Tuple

import numpy as np

from .._errors import ArrayError


class Response:
    """The response model of every link's taxels (see the module's docs)."""

    def __init__(
        self,
        ids: Sequence[np.ndarray],
        config: Mapping,
        *,
        busmap=None,
        polarity: str = "rising",
        baseline_frames: int = 20,
    ) -> None:
        self.config = dict(config)
        c = self.config
        if polarity == "falling" and float(c["rest"]) < float(c["full_scale"]) / 2:
            raise ArrayError(
                f"[sim] rest = {c['rest']:g} with falling polarity: pressure takes counts away from the rest, "
                f"so it must lie near full_scale ({c['full_scale']:g}); e.g. rest = 255 and full_scale = 255 for iCub"
            )
        self.baseline_frames = int(baseline_frames)
        # Complete frames delivered so far: missing modules wait for the baseline's.
        self.complete = 0
        self.full_scale = float(c["full_scale"])
        self.half_scale = float(c["half_scale_kpa"]) * 1e3
        self.noise = float(c["noise"])
        self.dropout = float(c["dropout"])
        self.sign = 1.0 if polarity == "rising" else -1.0
        self.rng = np.random.default_rng(int(c["seed"]))
        self.ids = [np.asarray(i, dtype=np.int64) for i in ids]
        self.gains = []
        self.rests = []
        dead = {int(t) for t in c["dead"]}
        known = set()
        self.dead = []
        for link_ids in self.ids:
            n = len(link_ids)
            self.gains.append(1.0 + float(c["gain_spread"]) * self.rng.uniform(-1.0, 1.0, n))
            self.rests.append(float(c["rest"]) + float(c["rest_spread"]) * self.rng.uniform(-1.0, 1.0, n))
            self.dead.append(np.isin(link_ids, list(dead)))
            known.update(int(t) for t in link_ids)
        unknown = sorted(dead - known)
        if unknown:
            raise ArrayError(f"[sim] dead: taxel {unknown[0]} is on no link of the layout")
        self.busmap = busmap
        self.modules: List[Tuple[str, int, np.ndarray]] = []
        self.always_missing: List[int] = []
        if busmap is not None:
            self._bus_layout(busmap)
        elif c["missing_modules"] or self.dropout > 0.0:
            raise ArrayError("[sim] missing_modules and dropout need a bus map (busmap = ... in the configuration)")

    def _bus_layout(self, busmap) -> None:
        slot_ids = np.asarray(busmap.ids, dtype=np.int64)
        # Each slot's (link, taxel) in the frame's readings; slots of no taxel of the layout
        # read their module's rest.
        where = {}
        for k, link_ids in enumerate(self.ids):
            for i, t in enumerate(link_ids):
                where.setdefault(int(t), (k, i))
        self.slot_link = np.full(len(slot_ids), -1, dtype=np.int64)
        self.slot_taxel = np.zeros(len(slot_ids), dtype=np.int64)
        for s, t in enumerate(slot_ids):
            if int(t) in where:
                self.slot_link[s], self.slot_taxel[s] = where[int(t)]
        # Per link, the slots it fills and from which of its taxels, made once.
        self.link_slots = [
            (np.flatnonzero(self.slot_link == k), self.slot_taxel[self.slot_link == k]) for k in range(len(self.ids))
        ]
        self.unused = np.flatnonzero(self.slot_link < 0)
        self.unused_reading = np.float32(np.clip(np.rint(self.config["rest"]), 0, self.full_scale))
        for k, link_ids in enumerate(self.ids):
            if len(link_ids) and not np.any(self.slot_link == k):
                raise ArrayError(f"the bus map carries none of link {k}'s {len(link_ids)} taxels: is it this skin's bus map?")
        self.modules = [(iface, int(addr), np.asarray(slots, dtype=np.int64)) for iface, addr, slots in busmap.modules]
        names = {f"{iface}:{addr}": m for m, (iface, addr, _) in enumerate(self.modules)}
        for name in self.config["missing_modules"]:
            if name not in names:
                raise ArrayError(f"[sim] missing_modules: {name} is no module of the bus map")
            self.always_missing.append(names[name])

    def counts(self, stress: Sequence[np.ndarray]) -> List[np.ndarray]:
        """Per link, the counts of the stress at its taxels (Pa)."""
        out = []
        for s, gain, rest, dead in zip(stress, self.gains, self.rests, self.dead):
            s = np.maximum(np.asarray(s, dtype=np.float64), 0.0)
            signal = gain * self.full_scale * s / (s + self.half_scale)
            noise = self.rng.normal(0.0, self.noise, len(s)) if self.noise > 0 else 0.0
            value = np.where(dead, rest, rest + self.sign * signal + noise)
            out.append(np.clip(np.rint(value), 0.0, self.full_scale).astype(np.float32))
        return out

    def readings(self, stress: Sequence[np.ndarray]) -> Tuple[List[np.ndarray], Optional[np.ndarray], List[Tuple[str, int]]]:
        """Per-link counts, the bus-map slots (None without a bus map) and the modules lost."""
        per_link = self.counts(stress)
        if self.busmap is None:
            return per_link, None, []
        slots = np.empty(len(self.slot_link), dtype=np.float32)
        slots[self.unused] = self.unused_reading
        for (where, taxels), values in zip(self.link_slots, per_link):
            slots[where] = values[taxels]
        lost = set(self.always_missing) if self.complete >= self.baseline_frames else set()
        if self.dropout > 0.0:
            lost.update(np.flatnonzero(self.rng.random(len(self.modules)) < self.dropout).tolist())
        self.complete += not lost
        missing = [(self.modules[m][0], self.modules[m][1]) for m in sorted(lost)]
        return per_link, slots, missing
