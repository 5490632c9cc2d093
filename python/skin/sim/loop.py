"""`skin` in the loop: MuJoCo steps, the skin's frames through the session, the events and the
gate's action at every control step; and, at every step, whatever presses into a link's skin
deeper than a skin gives (`Overpress`: a warning and a record the loop keeps)."""

from __future__ import annotations

import warnings
from collections import deque
from dataclasses import dataclass
from typing import Callable, Deque, Dict, List, Optional, Sequence, Tuple

import numpy as np

from .._errors import ArrayError, SessionError, SkinWarning, UnknownNameError
from .bridge import SimFrame, SkinBridge, _mujoco

#: control(loop) before each MuJoCo step: read loop.gate, loop.new_events(), loop.data.
Control = Callable[["SkinLoop"], None]

#: How many of the latest events `SkinLoop.events` keeps by default: about 5 MB (a `classified`
#: event carries its 68 x 100 image: some 15 kB a touch), some six minutes of a skin pressed
#: without pause (about 160 events a simulated minute in python/bench/sim_memory.py), however
#: long the session runs; every event of it, kept, would grow its memory without end.
MAX_EVENTS = 1_000


class JointReader:
    """The robot's joints a loop reports as joint states: `joints`, MuJoCo's joints of those
    names (the names its URDF gives them), read at every skin frame's step and every `period`
    seconds between (a robot driver publishes at 100 Hz or more)."""

    def __init__(self, model, joints: Sequence[str], period: float = 0.01) -> None:
        mujoco = _mujoco()
        self.names = list(joints)
        ids = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, j) for j in self.names]
        missing = [j for j, i in zip(self.names, ids) if i < 0]
        if missing:
            raise UnknownNameError(f"no joint {missing[0]!r} in the model")
        if not (np.isfinite(period) and period > 0):
            raise ArrayError(f"joint_period = {period}: seconds, more than 0")
        self._qadr = [int(model.jnt_qposadr[i]) for i in ids]
        self._vadr = [int(model.jnt_dofadr[i]) for i in ids]
        self._every = max(1, round(period / model.opt.timestep))

    def due(self, step: int, frame_step: bool) -> bool:
        """The step of this number (from time 0) reports the joints."""
        return frame_step or step % self._every == 0

    def read(self, data) -> Tuple[List[float], List[float]]:
        """Positions (rad or m) and velocities of the joints now."""
        return [float(data.qpos[a]) for a in self._qadr], [float(data.qvel[a]) for a in self._vadr]


@dataclass
class Overpress:
    """A geom pressed into a link's skin deeper than a skin gives (`bridge.allowed_depth`): a
    force beyond what the scene holds. From its start the touch MuJoCo images is wider than any
    cover makes it, and a little deeper the geom goes through the link; the frames go on to the
    session all the same. `through`: MuJoCo's contact normal turned over while the geom was in
    (it passed the middle of what it pressed and is on its way out of the other side)."""

    #: The link pressed.
    link: str
    #: The geom that pressed (its name, else "geom N").
    geom: str
    #: Seconds: the start of the first step deeper than allowed, and of the first step back
    #: within it (None while it lasts).
    start: float
    end: Optional[float]
    #: Metres: the deepest it went, and how deep it was allowed.
    depth: float
    allowed: float
    through: bool = False


class SkinLoop:
    """A MuJoCo model and a `skin.Session` stepped together: every `bridge.steps_per_frame`
    steps the skin delivers a frame (the step that starts it computes its sensor), the session
    takes it and its events are kept. A controller (`control`) is called before every step with
    this loop: `loop.gate` is the gate's action now ("stop", "comply", "slow", "resume", or None
    with no gate or no touch), `loop.new_events()` the events since it last asked.

    The loop keeps the latest `max_events` events in `loop.events` (`MAX_EVENTS` by default;
    None keeps every one, for a short scripted run) and counts those it let go in
    `loop.events_dropped`; what `step`, `run`, `finish` and `new_events` return is never cut
    by that bound.

    At every step the loop also looks for geoms pressed into a link's skin deeper than a skin
    gives: each such press warns (`skin.SkinWarning`) when it starts and if it goes through the
    link, and is kept in `loop.overpresses` (`Overpress`).

    `joints`: the robot's joints (MuJoCo's, named as the session's `[stitch] urdf` names them)
    whose angles go to the session as joint states (`Session.joint_states`) at every skin frame
    and every `joint_period` s between, as a robot's driver would send them: the session then
    places every touch in the chain's base frame (`centroid_base`)."""

    def __init__(
        self,
        model,
        data,
        bridge: SkinBridge,
        session,
        *,
        control: Optional[Control] = None,
        max_events: Optional[int] = MAX_EVENTS,
        joints: Optional[Sequence[str]] = None,
        joint_period: float = 0.01,
    ) -> None:
        if max_events is not None and (isinstance(max_events, bool) or not isinstance(max_events, int) or max_events < 0):
            raise ArrayError(f"max_events = {max_events!r}: a number of events, 0 or more (None keeps every one)")
        self.model = model
        self.data = data
        self.bridge = bridge
        self.session = session
        self.control = control
        #: The session's latest events, oldest first: at most `max_events` (a deque of that
        #: `maxlen`; every one with None).
        self.events: Deque = deque(maxlen=max_events)
        #: How many events `events` let go to stay within `max_events` (they were returned and
        #: delivered all the same).
        self.events_dropped = 0
        #: The last frame the skin delivered.
        self.frame: Optional[SimFrame] = None
        #: The last step made a skin frame.
        self.framed = False
        #: Every press deeper than a skin gives, in order of their start (`Overpress`).
        self.overpresses: List[Overpress] = []
        # The presses under way: per (link, geom), its record and its first normal.
        self._deep: Dict[Tuple[int, int], Tuple[Overpress, np.ndarray]] = {}
        # The events `new_events` has yet to return, kept apart from the history so that none is
        # lost to its bound; None until its first call (no reader yet: nothing kept twice).
        self._unread: Optional[List] = None
        self._mj = _mujoco()
        self._joints = JointReader(model, joints, joint_period) if joints is not None else None
        bridge.bind(model)
        self._check_session()
        # When the skin's sensors are the model's only ones, MuJoCo computes none between skin
        # frames (the same readings, without the sensor's per-step bookkeeping); any other
        # sensor keeps them all on, at every step.
        self._sensor_bit = int(self._mj.mjtDisableBit.mjDSBL_SENSOR)
        self._toggle = bridge.owns_all_sensors(model)

    # Where the session is: in this process here; a subclass puts it elsewhere (`ZenohLoop`:
    # in a `skin run` node) by overriding these five.

    def _check_session(self) -> None:
        _check_session(self.bridge, self.session)

    @property
    def gate(self) -> Optional[str]:
        """The gate's action now (None without a gate)."""
        return self.session.gate

    def _send_joints(self, joints: JointReader, before: float, frame_step: bool) -> None:
        """The robot's joints at the step starting at `before` (s) to the session."""
        q, _ = joints.read(self.data)
        self.session.joint_states(before, joints.names, q)

    def _deliver(self, frame: SimFrame, before: float) -> List:
        """The frame of the step starting at `before` to the session; its events."""
        return frame.push(self.session)

    def _between(self) -> List:
        """Events of a step without a skin frame (none from an in-process session)."""
        return []

    @property
    def time(self) -> float:
        return float(self.data.time)

    def new_events(self) -> List:
        """The events since the last call, every one however many: from its first call on, the
        loop keeps those not yet read until they are, whatever `max_events` says (so a caller
        that reads once and then stops keeps them all). The first call returns the events
        since the loop began as `events` holds them: every one, unless it had let some go
        before (`events_dropped`); a controller that calls it from its first step misses
        none."""
        if self._unread is None:
            self._unread = []
            return list(self.events)
        new, self._unread = self._unread, []
        return new

    def _record(self, events: List) -> None:
        """Events the session gave: into the history (counting what its bound lets go) and,
        once someone reads them, among the unread."""
        if not events:
            return
        bound = self.events.maxlen
        if bound is not None:
            # A deque at its maxlen lets go of its oldest as many as overflow it.
            self.events_dropped += max(0, len(self.events) + len(events) - bound)
        self.events.extend(events)
        if self._unread is not None:
            self._unread.extend(events)

    def step(self) -> List:
        """One control step and one MuJoCo step; returns the events of the skin frame it made
        (none between frames)."""
        return self._step()

    def _step(self) -> List:
        # (`step` and `run` both call it, so a warning points at their caller: 4 frames up.)
        if self.control is not None:
            self.control(self)
        # Frames on the simulation's clock, as the sensor's interval counts them: whatever time
        # the loop starts at (a reset, a keyframe, steps made before), a frame's step is one
        # whose start is a whole number of frame periods.
        before = self.data.time
        step = round(before / self.model.opt.timestep)
        frame_step = step % self.bridge.steps_per_frame == 0
        if self._joints is not None and self._joints.due(step, frame_step):
            self._send_joints(self._joints, before, frame_step)
        if self._toggle:
            opt = self.model.opt
            if frame_step:
                opt.disableflags &= ~self._sensor_bit
            else:
                opt.disableflags |= self._sensor_bit
        try:
            self._mj.mj_step(self.model, self.data)
        finally:
            # The model as the caller had it: sensors on.
            if self._toggle:
                self.model.opt.disableflags &= ~self._sensor_bit
        self.framed = frame_step
        if self.data.time <= before:
            # MuJoCo resets a diverging simulation to its start: say so instead of feeding the
            # session frames from the past.
            raise SessionError(
                f"the simulation diverged at t = {before:.4f} s and MuJoCo reset it "
                "(see its warning): smaller timestep, softer gains or lighter contacts"
            )
        self._watch(before)
        if not frame_step:
            events = self._between()
        else:
            self.frame = self.bridge.frame(self.data)
            events = self._deliver(self.frame, before)
        self._record(events)
        return events

    def _watch(self, t: float) -> None:
        """Presses deeper than a skin gives at the step that started at `t`: new ones warned of
        and recorded, those back within it closed."""
        found = self.bridge.too_deep(self.data) if self.data.ncon else []
        if not found and not self._deep:
            return
        seen = set()
        for k, geom, depth, allowed, normal in found:
            key = (k, geom)
            seen.add(key)
            if key not in self._deep:
                name = self.model.geom(geom).name or f"geom {geom}"
                press = Overpress(self.bridge.links[k], name, t, None, depth, allowed)
                self._deep[key] = (press, normal)
                self.overpresses.append(press)
                warnings.warn(
                    f"t = {t:.3f} s: {name} is {depth * 1e3:.1f} mm into link {press.link!r}, deeper than a skin "
                    f"gives there ({allowed * 1e3:g} mm): a press beyond what the scene holds, its readings "
                    "no skin's (Kit.force_limit; loop.overpresses keeps it)",
                    SkinWarning,
                    stacklevel=4,
                )
                continue
            press, first = self._deep[key]
            press.depth = max(press.depth, depth)
            if not press.through and float(normal @ first) < 0.0:
                press.through = True
                warnings.warn(
                    f"t = {t:.3f} s: {press.geom} went through link {press.link!r} (pressed in at {press.start:.3f} s)",
                    SkinWarning,
                    stacklevel=4,
                )
        for key in [key for key in self._deep if key not in seen]:
            self._deep.pop(key)[0].end = t

    def run(self, seconds: float, until: Optional[Callable[["SkinLoop"], bool]] = None) -> List:
        """Steps for `seconds` of simulated time (or until `until(loop)` is true); returns every
        event of that stretch, however many (`max_events` bounds only `events`: for a long
        session, run it a stretch at a time)."""
        if not (np.isfinite(seconds) and seconds >= 0):
            raise ArrayError(f"seconds = {seconds}: simulated seconds, 0 or more")
        stretch: List = []
        end = self.data.time + seconds - 0.5 * self.model.opt.timestep
        while self.data.time < end:
            stretch.extend(self._step())
            if until is not None and until(self):
                break
        return stretch

    def finish(self) -> List:
        """Ends the session (open touches released); returns those events."""
        events = self.session.finish()
        self._record(events)
        return events


def _check_session(bridge: SkinBridge, session) -> None:
    """The session is for this skin: the same links, taxels and input."""
    mine = [(l.name, len(l)) for l in bridge.layout.links]
    theirs = list(zip(session.links, session.taxels))
    if mine != theirs:
        raise ArrayError(f"the session's skin {theirs} is not the bridge's {mine}: build both from one configuration")


def touches(events) -> List[dict]:
    """The touches of a run's events, in order: per touch its `touch` number, `link`, `start`
    and `end` (seconds; None while open), the final `class` (None if undecided) and the `parts`
    of its last decision as a hand ([] otherwise)."""
    out: dict = {}
    for e in events:
        if e.kind == "appeared":
            out[e.touch] = {"touch": e.touch, "link": e.link, "start": e.time, "end": None, "class": None, "parts": []}
        elif e.kind in ("classified", "released") and e.touch in out:
            t = out[e.touch]
            if e.kind == "classified":
                t["class"] = e["class"]
                t["parts"] = e.parts if e["class"] == "hand" else t["parts"]
            else:
                t["end"] = e.time
                t["class"] = e["class"]
    return list(out.values())
