"""A force calibration rig: scripted presses of known force on a link's simulated skin, written as
the two files `skin calibrate-force` (and `skin.calibrate_force`) read, so that a calibration is
tested end to end without knowing the simulator's internals.

    from skin.sim import ForceRig
    rig = ForceRig("fixtures/session/run.toml")                 # its layout, bus map and [sim]
    presses = rig.script(30, seed=1)                             # ball, bar, plate; 1-30 N
    rig.record(presses, "presses.txt", "load.csv")               # recording + load cell
    skin.calibrate_force("fixtures/session/run.toml", "load.csv", recording="presses.txt",
                         output="force.json")

The recording is the skin's raw counts as `[sim]`'s response makes them (each taxel's gain,
saturation, noise); its time column is the simulation's clock. The load file is a load cell
under the skin, one sample per skin frame: `time_s,force_n,x_m,y_m,z_m`, the sum of MuJoCo's
normal contact forces on the link's skin and their force-weighted centre in the link's frame
(left empty where nothing presses), what `SkinBridge.load` reads. A press is a `Kit` press
(ramped up and down over 0.15 s); `weight` gives a mass's weight, for a plate laid on the skin.

The tools (`TOOLS`): a ball of 30 mm radius, a bar 50 mm long and 15 mm in radius, a square plate
30 mm a side (`BALL_RADIUS`, ...: contacts a few taxels wide), each of `tool_mass` kg (the scene holds a press of about 110 N per kg of tool:
`Kit.force_limit`). `ForceRig.script` places each press on a taxel far enough from the skin's
border for the whole tool to lie on the skin (`MARGIN_MM`), so that all of its load is the skin's.
"""

from __future__ import annotations

import os
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from .. import _skin
from .._errors import ArrayError, SkinError, UnknownNameError
from .bridge import SkinBridge, _mujoco
from .scenes import Kit, bare_robot

_PathLike = Union[str, "os.PathLike[str]"]

#: Standard gravity, m/s² (the value `skin calibrate-force` weighs a `mass_kg` with).
STANDARD_GRAVITY = 9.80665

#: The rig's tools.
TOOLS = ("ball", "bar", "plate")

#: The tools' sizes, metres.
BALL_RADIUS = 0.03
BAR_LENGTH, BAR_RADIUS = 0.05, 0.015
PLATE_WIDTH = 0.03

#: How far from the skin's border (mm, on its tactile map) a press of each tool is placed: the
#: tool's reach across the skin and a few millimetres more.
MARGIN_MM = {"ball": 12.0, "bar": 30.0, "plate": 26.0}


def weight(mass_kg: float) -> float:
    """A mass's weight, N."""
    return float(mass_kg) * STANDARD_GRAVITY


@dataclass(frozen=True)
class RigPress:
    """One press of the rig: `tool` (one of `TOOLS`) at `point` along `normal` (the link's
    frame: a taxel's position and outward normal), `force` newtons held for `duration` seconds
    (ramps included), the tool turned by `yaw` radians about the normal."""

    tool: str
    point: Tuple[float, float, float]
    normal: Tuple[float, float, float]
    force: float
    duration: float = 1.0
    yaw: float = 0.0


@dataclass(frozen=True)
class RigRun:
    """What `ForceRig.record` wrote, frame by frame (T frames): `times` (s), the `load` (N, the
    load file's), and `ideal` (N): what a force model that knew every taxel's stress exactly
    would read, the sum over the link's taxels of stress times the area each stands for
    (`TactileMap.areas`). `ideal` against `load` is the floor of any per-taxel force model on
    this skin: where a contact is narrow next to the taxels' pitch and the cover thin, the
    taxels sample its stress too coarsely to weigh it, whatever their calibration. `spans`:
    each press's start and end on the recording's clock (s, ramps included)."""

    times: np.ndarray
    load: np.ndarray
    ideal: np.ndarray
    spans: List[Tuple[float, float]]

    @property
    def frames(self) -> int:
        return len(self.times)


class ForceRig:
    """The MuJoCo bridge as a force calibration rig on link `link` (the layout's only link by
    default) of a run configuration's skin."""

    def __init__(self, config: _PathLike, *, link: Optional[str] = None, tool_mass: float = 0.4) -> None:
        self.config = Path(config)
        bridge = SkinBridge.from_config(self.config)
        self.layout = bridge.layout
        names = bridge.links
        if link is None:
            if len(names) != 1:
                raise ArrayError(f"the layout has {len(names)} links ({', '.join(names)}): name the one pressed (link=)")
            link = names[0]
        if link not in names:
            raise UnknownNameError(f"no link {link!r} (links: {names})")
        if not (np.isfinite(tool_mass) and tool_mass > 0):
            raise ArrayError(f"tool_mass = {tool_mass}: kilograms, more than 0")
        self.link = link
        self.tool_mass = float(tool_mass)
        skin_link = self.layout[link]
        self.positions = np.asarray(skin_link.positions)
        self.normals = np.asarray(skin_link.normals)
        # Each taxel's distance from the skin's border (mm) and the area it stands for (m²), in
        # layout order (the map orders taxels by id).
        tmap = _skin.flatten(skin_link)
        where = {int(i): k for k, i in enumerate(np.asarray(tmap.ids))}
        order = np.array([where[int(i)] for i in np.asarray(skin_link.ids)])
        self.border_mm = np.asarray(tmap.border_mm)[order]
        self.areas = np.asarray(tmap.areas)[order]

    def places(self, tool: str) -> np.ndarray:
        """The taxels (layout indices) a press of `tool` may be centred on: those at least
        `MARGIN_MM[tool]` from the skin's border."""
        if tool not in MARGIN_MM:
            raise UnknownNameError(f"no tool {tool!r} (tools: {', '.join(TOOLS)})")
        return np.flatnonzero(self.border_mm >= MARGIN_MM[tool])

    def script(
        self,
        count: int,
        *,
        seed: int = 1,
        tools: Sequence[str] = TOOLS,
        forces: Tuple[float, float] = (1.0, 30.0),
        duration: float = 1.0,
        places: Optional[Sequence[int]] = None,
    ) -> List[RigPress]:
        """`count` presses, the tools in turn, each on a random taxel among `places` (layout
        indices; every taxel by default) that lies far enough from the border for the tool
        (`places(tool)`), along its normal, turned at random, with a force drawn log-uniformly
        within `forces` (N: as many light presses as hard ones). Deterministic for `seed`."""
        if count < 1:
            raise ArrayError(f"count = {count}: at least 1")
        lo, hi = forces
        if not (np.isfinite(lo) and np.isfinite(hi) and 0 < lo <= hi):
            raise ArrayError(f"forces = {forces}: newtons, 0 < low <= high")
        rng = np.random.default_rng(seed)
        allowed = None if places is None else set(int(p) for p in places)
        pools: Dict[str, np.ndarray] = {}
        for tool in tools:
            pool = self.places(tool)
            if allowed is not None:
                pool = np.array([p for p in pool if int(p) in allowed], dtype=np.int64)
            if len(pool) == 0:
                raise ArrayError(f"no taxel of the places given lies {MARGIN_MM[tool]:g} mm from the border, as a {tool} needs")
            pools[tool] = pool
        out = []
        for k in range(count):
            tool = tools[k % len(tools)]
            i = int(rng.choice(pools[tool]))
            force = float(np.exp(rng.uniform(np.log(lo), np.log(hi))))
            yaw = float(rng.uniform(-np.pi, np.pi))
            out.append(RigPress(tool, tuple(self.positions[i]), tuple(self.normals[i]), force, duration, yaw))
        return out

    def record(
        self,
        presses: Sequence[RigPress],
        recording: _PathLike,
        load: _PathLike,
        *,
        settle: float = 1.5,
        gap: float = 0.5,
        overwrite: bool = False,
    ) -> RigRun:
        """Runs `presses` one after the other, `gap` seconds apart, after `settle` seconds with
        nothing touching (the session's baseline), and writes the skin's raw `recording` and
        the `load` cell's CSV. Both appear together and complete, or neither (they are written
        beside their places, then renamed). An existing file is refused, before anything is
        simulated, unless `overwrite` (and even then only a file of its kind: a recording, a
        load cell's CSV): a rig's files look like a real rig's, which must never be lost."""
        recording, load = Path(recording), Path(load)
        if recording.resolve() == load.resolve():
            raise ArrayError(f"{recording}: the recording and the load file must be two files")
        for path, kind in ((recording, "recording"), (load, "load")):
            _check_replaceable(path, kind, overwrite)
        mujoco = _mujoco()
        bridge = SkinBridge.from_config(self.config)
        spec = bare_robot(bridge.layout)
        kit = Kit(spec)
        m = self.tool_mass
        kit.add_sphere("ball", radius=BALL_RADIUS, mass=m)
        kit.add_bar("bar", length=BAR_LENGTH, radius=BAR_RADIUS, mass=m)
        kit.add_plate("plate", width=PLATE_WIDTH, thickness=0.004, mass=m)
        bridge.attach(spec)
        model = spec.compile()
        data = mujoco.MjData(model)
        kit.bind(model, data)
        spans = []
        t = float(settle)
        for p in presses:
            if p.tool not in TOOLS:
                raise UnknownNameError(f"no tool {p.tool!r} (tools: {', '.join(TOOLS)})")
            kit.press(p.tool, p.point, p.normal, p.force, t, p.duration, yaw=p.yaw, body=self.link)
            spans.append((t, t + p.duration))
            t += p.duration + gap
        end = t
        bridge.bind(model)
        steps = bridge.steps_per_frame
        dt = float(model.opt.timestep)
        k_link = bridge.links.index(self.link)
        times: List[float] = []
        loads: List[float] = []
        ideal: List[float] = []
        rows: List[np.ndarray] = []
        lines = ["time_s,force_n,x_m,y_m,z_m"]
        while data.time < end - 0.5 * dt:
            kit.control()
            framed = round(data.time / dt) % steps == 0
            mujoco.mj_step(model, data)
            if not framed:
                continue
            frame = bridge.frame(data)
            force, point = bridge.load(data, self.link)
            times.append(frame.time)
            loads.append(force)
            ideal.append(float(frame.stress[k_link] @ self.areas))
            rows.append(np.concatenate(frame.readings))
            where = ",,," if point is None else "," + ",".join(f"{v:.6f}" for v in point)
            lines.append(f"{frame.time:.6f},{force:.6f}{where}")
        ids = np.concatenate([np.asarray(l.ids, dtype=np.int64) for l in bridge.layout.links])
        # Both written beside their places first, then renamed: the pair appears together.
        staged_rec = _partial(recording)
        staged_load = _partial(load)
        try:
            _skin.write_recording(staged_rec, ids, np.asarray(times), np.asarray(rows, dtype=np.float32))
            _write_atomically(staged_load, "\n".join(lines) + "\n")
            os.replace(staged_load, load)
            os.replace(staged_rec, recording)
        finally:
            for p in (staged_rec, staged_load):
                if p.exists():
                    p.unlink()
        return RigRun(np.asarray(times), np.asarray(loads), np.asarray(ideal), spans)


@dataclass(frozen=True)
class RigReading:
    """A calibrated session's reading of a rig's files, frame by frame (T frames): the load
    cell's `load` (N) and `point` (link frame, m; NaN with nothing pressing), and the session's
    summed contact `force` (N; 0 with no contact), its wrench's `torque` about the link's origin
    (N m) and centre of pressure `cop` (m; NaN without contact)."""

    times: np.ndarray
    load: np.ndarray
    point: np.ndarray
    force: np.ndarray
    wrench: np.ndarray
    torque: np.ndarray
    cop: np.ndarray

    def cop_error(self) -> np.ndarray:
        """Per frame, how far (m) the session's centre of pressure lies from the load's point
        across the skin: the distance in the plane normal to the wrench's force (MuJoCo puts a
        contact between the two surfaces it presses together, a millimetre or two out of the
        skin, where the session's centre lies on the taxels). NaN where either is missing."""
        d = self.cop - self.point
        n = -self.wrench / np.maximum(np.linalg.norm(self.wrench, axis=1, keepdims=True), 1e-12)
        across = d - n * np.sum(d * n, axis=1, keepdims=True)
        return np.linalg.norm(across, axis=1)

    def relative_error(self, within: Tuple[float, float] = (2.0, 20.0)) -> np.ndarray:
        """|force - load| / load over the frames whose load lies `within` (N)."""
        keep = (self.load >= within[0]) & (self.load <= within[1])
        return np.abs(self.force[keep] - self.load[keep]) / self.load[keep]


def read_with(session, recording: _PathLike, load: _PathLike, link: Optional[str] = None) -> RigReading:
    """Runs `recording` (a rig's: every link's taxels in layout order) through `session`
    (a `skin.Session` whose run configuration names a force calibration) frame by frame, with the
    `load` cell's CSV beside it (`time_s,force_n,x_m,y_m,z_m`, a sample per frame, as `record`
    writes it): what the session reads against what pressed (`RigReading`). `link`: the link
    pressed, the session's only one by default."""
    if link is None:
        if len(session.links) != 1:
            raise ArrayError(f"the session has {len(session.links)} links ({', '.join(session.links)}): name the one pressed (link=)")
        link = session.links[0]
    rec = _skin.read_recording(recording)
    table = np.genfromtxt(load, delimiter=",", skip_header=1, ndmin=2)
    if table.shape[1] != 5 or len(table) != len(rec):
        raise ArrayError(f"{load}: {len(table)} samples of {table.shape[1]} columns for {len(rec)} frames: not the load file of {recording}")
    if not np.allclose(table[:, 0], rec.times, atol=1e-5):
        raise ArrayError(f"{load}: its times are not those of {recording}'s frames")
    n = len(rec)
    force = np.zeros(n)
    wrench = np.zeros((n, 3))
    torque = np.zeros((n, 3))
    cop = np.full((n, 3), np.nan)
    # A rig's recording holds every link's taxels, in layout order.
    if len(rec.ids) != sum(session.taxels):
        raise ArrayError(f"{recording}: {len(rec.ids)} taxels, the session's skin {sum(session.taxels)}: not a rig recording of this skin")
    cuts = np.cumsum(session.taxels)[:-1]
    values = rec.values
    for k, t in enumerate(rec.times):
        session.push(np.split(values[k], cuts), float(t))
        force[k] = sum(c.force_n or 0.0 for c in session.contacts(link))
        w = session.wrench(link)
        if w is None:
            raise ArrayError(f"the session has no force calibration for link {link!r}: name one in its run.toml ([force])")
        wrench[k], torque[k] = w[0], w[1]
        if w[2] is not None:
            cop[k] = w[2]
    session.finish()
    return RigReading(rec.times, table[:, 1], table[:, 2:5], force, wrench, torque, cop)


def _check_replaceable(path: Path, kind: str, overwrite: bool) -> None:
    """`path` may be written: it does not exist, or `overwrite` and it is a file of `kind`."""
    if not path.exists():
        if not path.parent.is_dir():
            raise ArrayError(f"{path}: its folder {path.parent} does not exist")
        return
    if not overwrite:
        raise ArrayError(f"{path}: exists; not replaced (give overwrite=True, or --overwrite, to replace a rig's file)")
    if kind == "load":
        with open(path, "rb") as f:
            ours = f.read(32).startswith(b"time_s,force_n")
    else:
        try:
            _skin.read_recording(path)
            ours = True
        except Exception:
            ours = False
    if not ours:
        what = "a load cell's CSV (time_s,force_n...)" if kind == "load" else "a raw recording"
        raise ArrayError(f"{path}: exists and is not {what}: not replaced")


def _partial(path: Path) -> Path:
    """Where `path` is written before it is complete: beside it, a name no finished file has."""
    return path.with_name(f".{path.name}.{os.getpid()}.partial")


def _write_atomically(path: Path, text: str) -> None:
    """`text` into `path`, complete or not at all: a file beside it, renamed over it."""
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".partial", dir=path.parent or ".")
    try:
        # mkstemp's file is the owner's alone; the file written is as any other the user makes.
        umask = os.umask(0)
        os.umask(umask)
        os.fchmod(fd, 0o666 & ~umask)
        with os.fdopen(fd, "w") as f:
            f.write(text)
        os.replace(tmp, path)
    except BaseException:
        os.unlink(tmp)
        raise


def main(argv: Optional[Sequence[str]] = None) -> int:
    """`python -m skin.sim`: a rig's two files for a scripted series of presses."""
    import argparse

    ap = argparse.ArgumentParser(
        prog="python -m skin.sim",
        description=(
            "Scripted presses of known force on a run configuration's simulated skin (MuJoCo), written as a raw "
            "recording and a load cell's CSV (time_s,force_n,x_m,y_m,z_m: N, and metres in the link's frame): "
            "the two files `skin calibrate-force CONFIG --recording RECORDING --load LOAD -o FORCE.json` reads."
        ),
    )
    ap.add_argument("config", help="run configuration (run.toml): its layout, bus map and [sim] response")
    ap.add_argument("recording", help="the raw recording to write")
    ap.add_argument("load", help="the load cell's CSV to write")
    ap.add_argument("--link", help="the link pressed (default: the layout's only link)")
    ap.add_argument("--presses", type=int, default=60, help="presses, the tools in turn (default 60)")
    ap.add_argument("--tools", default=",".join(TOOLS), help=f"tools, comma-separated (default {','.join(TOOLS)})")
    ap.add_argument("--forces", default="1,30", help="lowest and highest force, N (default 1,30; drawn log-uniformly)")
    ap.add_argument("--seed", type=int, default=1, help="the script's seed (default 1)")
    ap.add_argument("--overwrite", action="store_true", help="replace a recording and a load file a rig wrote before")
    a = ap.parse_args(argv)
    try:
        lo, hi = (float(v) for v in a.forces.split(","))
    except ValueError:
        ap.error(f"--forces {a.forces}: two numbers, low,high (newtons)")
    try:
        rig = ForceRig(a.config, link=a.link)
        presses = rig.script(a.presses, seed=a.seed, tools=tuple(a.tools.split(",")), forces=(lo, hi))
        run = rig.record(presses, a.recording, a.load, overwrite=a.overwrite)
    except SkinError as e:
        # (A KeyError's str quotes its message.)
        print(f"error: {e.args[0] if e.args else e}", file=sys.stderr)
        return 1
    print(f"{len(presses)} presses, {run.frames} frames ({run.times[-1]:.1f} s): wrote {a.recording} and {a.load}")
    return 0

