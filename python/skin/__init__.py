"""skin: large-area robot skin from Python.

Thousands of taxels over a robot's links, from their layout to the decisions of the per-frame
session, with numpy arrays in and out::

    import skin
    layout = skin.read_layout("fixtures/forearm/layout.json")
    tmap = skin.flatten(layout["forearm"])            # tactile map: tmap.uv (N, 2) metres
    imager = skin.Imager(tmap)                         # built once
    image = imager.image(frame)                        # (N,) readings -> (rows, cols) uint8

    session = skin.Session.from_config("fixtures/session/run.toml")
    for event in session.run_log("fixtures/session/session.candump.log"):
        print(event.kind, event.time, getattr(event, "class", None))

    skin.export(["fixtures/session/session.candump.log"], "fixtures/session/run.toml", "dataset")
    # a LeRobot v3 dataset: raw counts per frame, events, contacts (skin.ray: on a Ray cluster)

Units: metres, seconds, raw counts (pressures above the baseline in events); each event
kind's fields as types in `skin.events`. Errors are
`SkinError` subclasses carrying the command line's messages; bad arguments are `ArrayError`
(also a `ValueError`) naming the argument.
"""

from ._errors import (
    ArrayError,
    ConfigError,
    ControlError,
    GeometryError,
    InputError,
    MissingFileError,
    ModelError,
    NotReadyError,
    SessionError,
    SkinError,
    SkinWarning,
    UnknownNameError,
)
from ._skin import (
    BusMap,
    Calibration,
    CanFrame,
    Contact,
    Event,
    Imager,
    Layout,
    Link,
    LogFrames,
    Recording,
    Session,
    TactileMap,
    TaskStack,
    __version__,
    calibrate,
    calibrate_force,
    export,
    flatten,
    read_grey,
    read_layout,
    read_log,
    read_map,
    read_probes,
    read_recording,
    read_session_settings,
    read_sim_config,
    synthesize,
    write_recording,
)
from . import events
from .dataset import SynthDataset

__all__ = [
    "ArrayError",
    "BusMap",
    "Calibration",
    "CanFrame",
    "ConfigError",
    "Contact",
    "ControlError",
    "Event",
    "GeometryError",
    "Imager",
    "InputError",
    "Layout",
    "Link",
    "LogFrames",
    "MissingFileError",
    "ModelError",
    "NotReadyError",
    "Recording",
    "Session",
    "SessionError",
    "SkinError",
    "SkinWarning",
    "SynthDataset",
    "TactileMap",
    "TaskStack",
    "UnknownNameError",
    "__version__",
    "calibrate",
    "calibrate_force",
    "events",
    "export",
    "flatten",
    "read_grey",
    "read_layout",
    "read_log",
    "read_map",
    "read_probes",
    "read_recording",
    "read_session_settings",
    "read_sim_config",
    "synthesize",
    "write_recording",
]
