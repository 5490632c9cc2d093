"""The session's events as types: one `TypedDict` per kind, the dict `Event.to_dict()` returns
(the line `skin run` writes to events.jsonl), and `EventKind`, the names `Event.kind` takes.

A type checker then knows each kind's fields::

    from skin.events import EventDict

    def on_event(line: EventDict) -> None:
        if line["event"] == "classified":
            print(line["class"], line["probability"])  # str, float
        elif line["event"] == "gate":
            print(line["action"])  # "stop" | "comply" | "slow" | "resume"

Units as in events.jsonl: times in seconds from the session's first frame (rounded to 1 ms),
centroids in metres (to 0.1 mm; `centroid` in the link's frame, `centroid_base` in the chain's
base frame), areas in cm², pressures in counts above the baseline. The kinds
are those of the Rust `skin_runtime::session::Event`; `tests/test_session.py` holds the events
of the fixture sessions (7 of the 11 kinds: all but `counter_reset`, `baseline_corrected`, `tare` and `joint_states`) to
these keys and types.
"""

from typing import List, Literal, TypedDict, Union, get_args

__all__ = [
    "EventKind",
    "GateAction",
    "PartName",
    "EventDict",
    "Footprint",
    "PartContact",
    "MissingModule",
    "IncompleteEvent",
    "CounterResetEvent",
    "AppearedEvent",
    "ClassifiedEvent",
    "ReleasedEvent",
    "GateEvent",
    "AcrossJointEvent",
    "AcrossJointEndEvent",
    "BaselineCorrectedEvent",
    "TareEvent",
    "JointStatesEvent",
    "EVENT_KINDS",
]

EventKind = Literal[
    "incomplete",
    "counter_reset",
    "appeared",
    "classified",
    "released",
    "gate",
    "across_joint",
    "across_joint_end",
    "baseline_corrected",
    "tare",
    "joint_states",
]
"""`Event.kind`: the `"event"` field of events.jsonl."""

EVENT_KINDS = get_args(EventKind)
"""Every `EventKind`, in the order the Rust enum declares them."""

GateAction = Literal["stop", "comply", "slow", "resume"]
"""What the gate tells the robot to do."""

PartName = Literal["thumb", "index", "middle", "ring", "pinkie", "palm"]
"""A part of the hand, as the segmenter names it."""


class _Force(TypedDict, total=False):
    force_n: float
    centroid_base: List[float]


class Footprint(_Force):
    """A touch's extent in one frame; `force_n` (newtons) on a link with a force calibration;
    `centroid_base` (metres, in the frame of `[stitch] base`, or of a poses file's poses) where
    the link's pose then is known (fresh joint states with `[stitch] urdf`, or a poses file)."""

    contacts: int
    taxels: int
    area_cm2: float
    mean_pressure: float
    centroid: List[float]


class _PartCentroid(TypedDict, total=False):
    centroid: List[float]


class PartContact(_PartCentroid):
    """One part of a hand pressing: its taxels and their pressure, and `centroid` (metres, the
    link's frame) where the map knows its taxels' 3D positions."""

    part: PartName
    taxels: int
    mean_pressure: float


class MissingModule(TypedDict):
    """A module whose readings a frame lacks."""

    bus: str
    address: int


class IncompleteEvent(TypedDict):
    """A frame came with modules missing; it was still processed."""

    event: Literal["incomplete"]
    time: float
    missing: List[MissingModule]


# `from` is a Python keyword: the functional form names it.
CounterResetEvent = TypedDict(
    "CounterResetEvent",
    {"event": Literal["counter_reset"], "time": float, "bus": str, "from": int, "to": int, "cycle": int},
)
"""A bus's sync counter restarted; the frames after it are numbered on by time."""


class AppearedEvent(_Force):
    """A touch began on a link: its number and its footprint's fields (`force_n`, newtons, on a
    link with a force calibration; `centroid_base`, metres in the chain's base frame, where the
    link's pose is known)."""

    event: Literal["appeared"]
    time: float
    link: str
    touch: int
    contacts: int
    taxels: int
    area_cm2: float
    mean_pressure: float
    centroid: List[float]


_ClassifiedFields = TypedDict(
    "_ClassifiedFields",
    {
        "event": Literal["classified"],
        "time": float,
        "link": str,
        "touch": int,
        "revised": bool,
        "class": str,
        "probability": float,
    },
)


class ClassifiedEvent(_ClassifiedFields, total=False):
    """A touch was classified on its fullest image so far: `border_mm`, how near its taxels come
    to the skin's border (millimetres on the map; left out when the image shows no pressed
    taxel), and `parts` only for a hand, with a segmenter."""

    border_mm: float
    parts: List[PartContact]


# Left out of the line for a touch released before it was decided (`class` is a Python
# keyword: the functional form names it).
_ReleasedDecision = TypedDict("_ReleasedDecision", {"class": str, "probability": float}, total=False)


class ReleasedEvent(_ReleasedDecision):
    """A touch ended: its duration, frames and peak footprint; `class` and `probability` once decided."""

    event: Literal["released"]
    time: float
    link: str
    touch: int
    duration: float
    frames: int
    peak: Footprint


class _OverForce(TypedDict, total=False):
    link: str
    touch: int
    force_n: float
    limit_n: float
    saturated: bool


class GateEvent(_OverForce):
    """What the robot should do changed; when it stops because a touch pressed past its class's
    force limit (`[gate] force_n`), that touch's `link`, `touch`, `force_n` and `limit_n` (N)."""

    event: Literal["gate"]
    time: float
    action: GateAction


class AcrossJointEvent(TypedDict):
    """A contact spans a joint; `centroid` in the poses' common frame."""

    event: Literal["across_joint"]
    time: float
    links: List[str]
    taxels: int
    centroid: List[float]


class AcrossJointEndEvent(TypedDict):
    """No contact spans a joint any more."""

    event: Literal["across_joint_end"]
    time: float


class BaselineCorrectedEvent(TypedDict):
    """Taxels whose no-contact offsets had been learned under pressure were reset."""

    event: Literal["baseline_corrected"]
    time: float
    since: float
    link: str
    taxels: int


class TareEvent(TypedDict):
    """The skin was tared (`Session.tare`): the baseline is learned again over `frames` frames,
    which read no pressure; a forced tare released the touches open first."""

    event: Literal["tare"]
    time: float
    frames: int
    forced: bool
    released: int


class JointStatesEvent(TypedDict):
    """The joint states that place the stitched links went wrong (once when a fault begins):
    `problem` is missing, not_finite, stale, out_of_order, other_robot, malformed or
    unstitchable; the last good posture holds."""

    event: Literal["joint_states"]
    time: float
    problem: str
    joints: List[str]
    detail: str


EventDict = Union[
    IncompleteEvent,
    CounterResetEvent,
    AppearedEvent,
    ClassifiedEvent,
    ReleasedEvent,
    GateEvent,
    AcrossJointEvent,
    AcrossJointEndEvent,
    BaselineCorrectedEvent,
    TareEvent,
    JointStatesEvent,
]
"""`Event.to_dict()`: the line of events.jsonl, by kind (`line["event"]` tells which)."""
