"""skin in simulation: a real skin layout as a MuJoCo sensor, its frames through the same session.

    import mujoco, skin
    from skin.sim import SkinBridge, SkinLoop, Kit, bare_robot

    bridge = SkinBridge.from_config("fixtures/session/run.toml")   # layout, bus map, [sim]
    spec = bare_robot(bridge.layout)            # or your robot's MjSpec (robot_from_urdf, ...)
    kit = Kit(spec)                             # tools to press with
    kit.add_sphere()
    bridge.attach(spec)                         # each link's skin on the body of its name
    model = spec.compile(); data = mujoco.MjData(model)
    kit.bind(model, data)
    kit.press("sphere", point=[0, 0.18, 0.08], normal=[0, 0, 1], force=5.0, start=1.5, duration=1.0)
    loop = SkinLoop(model, data, bridge, skin.Session.from_config("fixtures/session/run.toml"), control=kit.control)
    for event in loop.run(3.0) + loop.finish():
        print(event)

How a taxel is simulated. MuJoCo's `tactile` sensor reports, at every vertex of a mesh placed on a
body, how deep another geom presses into it; it places its taxels at given points (the mesh's
vertices), on any body, and is computed once per skin frame (its `interval`). So each link's skin
becomes a sensor mesh: the layout's triangles cut to 3 mm, finer than the taxels, because a real
taxel also feels a touch between its neighbours through the cover. MuJoCo's contact forces
(`mj_contactForce`) are spread over that surface in proportion to how deep each point is pressed,
and the cover (Boussinesq's kernel through its thickness, as in the calibration tests' elastic
probe) carries them to the taxels; `Response` makes counts of that stress as the run
configuration's `[sim]` says. MuJoCo's other option, the `touch_grid` plugin, images forces on a
grid of a site's frame, not at given points on a link. See `bridge`, `surface`, `response`.

What a scene holds. MuJoCo's contacts are soft: pressed too hard, a tool sinks deeper than a skin
gives and then through the link. `Kit` refuses a press beyond its tool's `Kit.force_limit` (it
grows with the tool's mass); `SkinLoop` warns of anything pressed deeper at any step
(`skin.SkinWarning`) and keeps it (`SkinLoop.overpresses`, `Overpress`).

Over ROS 2's middleware. `skin.sim.zenoh.ZenohLoop` runs the same scene against a `skin run`
node in its own process: the robot's joint states go out on Zenoh as an rmw_zenoh node sends
them, the skin's CAN traffic through a pipe, and the controller hears the gate on /skin/events
(the same events as `SkinLoop`'s; needs `pip install eclipse-zenoh`).

Needs `pip install mujoco` (MuJoCo 4, Python 3.11 or later). Units: metres, newtons, seconds,
pascals for stress, raw counts for readings.
"""

import sys

if sys.version_info < (3, 11):  # pragma: no cover - said to the user
    raise ImportError("skin.sim needs Python 3.11 or later (MuJoCo 4 does)")

from .arm import PathFollower, two_joint_arm
from .bridge import SimFrame, SkinBridge, robot_from_urdf
from .loop import Overpress, SkinLoop, touches
from .response import Response
from .rig import ForceRig, RigPress, RigReading, RigRun, read_with, weight
from .scenes import FINGERS, Action, Kit, Tool, bare_robot
from .surface import Kernel, Surface, boussinesq, sample_surface

__all__ = [
    "FINGERS",
    "Action",
    "ForceRig",
    "Kernel",
    "Kit",
    "Overpress",
    "PathFollower",
    "Response",
    "RigPress",
    "RigReading",
    "RigRun",
    "SimFrame",
    "SkinBridge",
    "SkinLoop",
    "Surface",
    "Tool",
    "bare_robot",
    "boussinesq",
    "read_with",
    "robot_from_urdf",
    "sample_surface",
    "touches",
    "two_joint_arm",
    "weight",
]
