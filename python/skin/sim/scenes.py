"""A scene kit for tests and examples: a sphere, a bar, a flat plate and a simple hand, pressing, sliding,
rolling and grasping a skin (`Kit.press`, `slide`, `grasp`, `random_presses`), scripted like
the fixture session.

Every tool is a free body with no gravity, driven each step by a wrench (`xfrc_applied`): a
stiff spring to the script's pose across the surface and about its axes, and along the surface's
normal either the same spring (moving, lifting) or a given force (pressing). A tool presses with
its -z side: a press at point p with normal n puts the tool's z axis on n. Between actions a
tool waits parked far from the skin. A press may not be harder than the scene holds: past
`Kit.force_limit` its tool would sink deeper into the skin than a skin gives (it grows with the
tool's mass: 22 N for the 0.2 kg ball, whatever its size).

The hand (right by default, `left=True` mirrors it): in its frame y points to the fingertips, x
to the thumb, z to the back of the hand, and its origin is halfway from wrist to fingertip. Its palm is four pads side by side and the thenar, each
on a spring along z, so the palm settles on a curved link as a hand's does; its flesh is softer
than MuJoCo's default contact; a finger is two capsules on two hinges (the thumb on the
thenar), each with a
torque motor. A pressing finger is flexed onto the surface (it settles on it, flat or curved)
and bears 12% of the hand's force; a lifted one is stretched back to its stop.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np

from .._errors import ArrayError, NotReadyError, UnknownNameError
from .bridge import _mujoco, check_timestep, collide, holding_force, skin_geoms

FINGERS = ("thumb", "index", "middle", "ring", "pinkie")

#: Parked tools wait this far above the world's origin, metres.
PARK_HEIGHT = 2.0

#: A pressing finger bears this share of the hand's force (flexed onto the surface by torques on
#: its two hinges, as a pad halfway along it would); a lifted one is stretched back to its stop,
#: away from the surface, by LIFT_TORQUE (N m).
FINGER_SHARE = 0.12
LIFT_TORQUE = (-0.08, -0.03)

#: The palm's pads: how far each gives way (m) and its spring (N/m), and the contact softness
#: of the hand's flesh (MuJoCo's solref: time constant, damping ratio; the default is 0.02).
PALM_TRAVEL = 0.015
PALM_STIFFNESS = 400.0
FLESH_SOLREF = (0.05, 1.0)
#: ...and its impedance (MuJoCo's solimp): soft at first touch, stiffer 2 cm in, as flesh is
#: (a palm pressed with 15 N sinks about 7 mm, so its whole surface bears on the skin).
FLESH_SOLIMP = (0.2, 0.95, 0.02, 0.5, 2.0)

#: Tools touch the skin and the robot, not one another nor themselves (contype / conaffinity
#: bits: MuJoCo's default geoms are 1 / 1).
TOOL_CONTYPE, TOOL_CONAFFINITY = 2, 1


#: Links of a bare robot lie side by side along x, this far apart (metres).
LINK_GAP = 0.1


def bare_robot(layout, *, timestep: float = 0.002):
    """A `mujoco.MjSpec` with one fixed body per link of `layout`, named after it (its taxels'
    positions are in that body's frame): a skin with no robot model. A layout says where taxels
    sit on each link, not where links are, so the first link's frame is the world's and each
    next one lies beside the last along x, `LINK_GAP` apart (press a link with `body=`).
    `timestep`: seconds, `bridge.MIN_TIMESTEP` to `bridge.MAX_TIMESTEP`."""
    mujoco = _mujoco()
    spec = mujoco.MjSpec()
    spec.option.timestep = check_timestep(timestep)
    x = 0.0
    for k, link in enumerate(layout.links):
        p = np.asarray(link.positions)
        if k > 0:
            x -= p[:, 0].min()
        spec.worldbody.add_body(name=link.name, pos=[x, 0.0, 0.0])
        x += p[:, 0].max() + LINK_GAP
    return spec


@dataclass
class Tool:
    """A tool of the kit: its body, how far its pressing side lies under its origin (metres),
    and for a hand its fingers' actuators."""

    name: str
    kind: str
    reach: float
    park: np.ndarray
    actuators: Dict[str, Tuple[str, str]] = field(default_factory=dict)
    lever: Dict[str, Tuple[float, float]] = field(default_factory=dict)
    joints: List[Tuple[int, int]] = field(default_factory=list)
    geoms: Dict[str, List[str]] = field(default_factory=dict)
    # Set by Kit.bind:
    body: int = -1
    qpos: int = -1
    qvel: int = -1
    mass: float = 0.0
    inertia: np.ndarray = field(default_factory=lambda: np.ones(3))
    ctrl: Dict[str, Tuple[int, int]] = field(default_factory=dict)
    geom_ids: Dict[str, np.ndarray] = field(default_factory=dict)
    #: The largest force it may press a skin of the model with (N; `Kit.force_limit`), and how
    #: deep it then sinks (m).
    limit: float = np.inf
    limit_depth: float = 0.0


def _positive(**values: float) -> None:
    for name, v in values.items():
        if not (np.isfinite(v) and v > 0):
            raise ArrayError(f"{name} = {v}: more than 0 (metres, kilograms)")


def _descends(model, body: int, root: int) -> bool:
    """`body` is `root` or lies under it in the model's tree."""
    while body > 0:
        if body == root:
            return True
        body = int(model.body_parentid[body])
    return False


def _quat_from_z(n: np.ndarray, yaw: float) -> np.ndarray:
    """The rotation whose z axis is n, turned by yaw about it (w, x, y, z)."""
    n = n / np.linalg.norm(n)
    ref = np.array([0.0, 1.0, 0.0]) if abs(n[1]) < 0.9 else np.array([1.0, 0.0, 0.0])
    x = np.cross(ref, n)
    x /= np.linalg.norm(x)
    y = np.cross(n, x)
    c, s = np.cos(yaw), np.sin(yaw)
    x, y = c * x + s * y, -s * x + c * y
    m = np.column_stack([x, y, n])
    q = np.zeros(4)
    _mujoco().mju_mat2Quat(q, m.ravel())
    return q


@dataclass
class Action:
    """What one tool does from `start` for `duration` seconds: moves along `path` (world points on
    the surface; one point for a press) with its z axis on `normal` (one, or one per point),
    pressing with `force`
    newtons (ramped up and down over `ramp` seconds), turned by `yaw` about the normal. `fingers`
    (a hand): those that press, the others lifted (all by default). `roll`: the tool's
    orientation is left free (a ball rolls instead of sliding). `body`: the path and normals are
    in that body's frame and move with it (a press on a moving link); world by default."""

    tool: str
    path: np.ndarray
    normal: np.ndarray
    force: float
    start: float
    duration: float
    yaw: float = 0.0
    fingers: Optional[Sequence[str]] = None
    roll: bool = False
    ramp: float = 0.15
    body: Optional[str] = None
    _quat: Optional[np.ndarray] = field(default=None, repr=False, compare=False)

    def _along(self, values: np.ndarray, t: float) -> np.ndarray:
        if len(values) == 1:
            return values[0]
        u = np.clip((t - self.start - self.ramp) / max(self.duration - 2 * self.ramp, 1e-9), 0.0, 1.0)
        seg = u * (len(values) - 1)
        k = min(int(seg), len(values) - 2)
        a = seg - k
        return (1 - a) * values[k] + a * values[k + 1]

    def target(self, t: float) -> np.ndarray:
        """The point of the path at time t (linear in time between its points, which it passes
        at an even pace between the ramps)."""
        return self._along(self.path, t)

    def normal_at(self, t: float) -> np.ndarray:
        """The normal at time t: one for the whole action, or one per point of the path."""
        n = self._along(self.normal, t)
        return n / np.linalg.norm(n)

    def force_at(self, t: float) -> float:
        """The pressing force at time t: up over the first ramp, down over the last."""
        into = t - self.start
        left = self.start + self.duration - t
        return self.force * float(np.clip(min(into, left) / self.ramp, 0.0, 1.0))


class Kit:
    """Tools added to a spec, then driven by a script of `Action`s."""

    def __init__(self, spec) -> None:
        self.spec = spec
        self.tools: Dict[str, Tool] = {}
        self.actions: List[Action] = []
        # Each tool's actions by start, and the first of them not yet over.
        self._by_tool: Dict[str, List[Action]] = {}
        self._next: Dict[str, int] = {}
        self.model = None
        self.data = None

    # --- building -------------------------------------------------------------------------

    def _body(self, name: str, reach: float, kind: str):
        if name in self.tools or self.spec.body(name) is not None:
            raise ArrayError(f"the model has a body {name!r} already: give the tool another name")
        park = np.array([0.5 * len(self.tools), 0.0, PARK_HEIGHT])
        body = self.spec.worldbody.add_body(name=name, pos=park.tolist())
        # A tool is held: gravity does not pull it (the robot's bodies keep theirs).
        body.gravcomp = 1.0
        body.add_freejoint(name=f"{name}_free")
        self.tools[name] = Tool(name=name, kind=kind, reach=reach, park=park)
        return body

    def add_sphere(self, name: str = "sphere", *, radius: float = 0.02, mass: float = 0.2) -> Tool:
        """A ball of `radius` metres."""
        _positive(radius=radius, mass=mass)
        mujoco = _mujoco()
        b = self._body(name, radius, "sphere")
        g = b.add_geom(name=f"{name}_ball", type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[radius, 0, 0], mass=mass)
        g.rgba = [0.2, 0.5, 0.9, 1]
        self._collide(g)
        self.tools[name].geoms["ball"] = [f"{name}_ball"]
        return self.tools[name]

    def add_bar(self, name: str = "bar", *, length: float = 0.25, radius: float = 0.012, mass: float = 0.3) -> Tool:
        """A round bar `length` metres long along the tool's y axis (as a hand's fingers)."""
        _positive(length=length, radius=radius, mass=mass)
        mujoco = _mujoco()
        b = self._body(name, radius, "bar")
        g = b.add_geom(
            name=f"{name}_rod",
            type=mujoco.mjtGeom.mjGEOM_CAPSULE,
            fromto=[0, -length / 2, 0, 0, length / 2, 0],
            size=[radius, 0, 0],
            mass=mass,
        )
        g.rgba = [0.6, 0.6, 0.6, 1]
        self._collide(g)
        self.tools[name].geoms["rod"] = [f"{name}_rod"]
        return self.tools[name]

    def add_plate(self, name: str = "plate", *, width: float = 0.03, thickness: float = 0.004, mass: float = 0.3) -> Tool:
        """A flat square plate, `width` metres a side and `thickness` thick, pressing with its
        face (a weight laid on the skin: `Kit.press` with its weight, `mass * 9.80665` N)."""
        _positive(width=width, thickness=thickness, mass=mass)
        mujoco = _mujoco()
        b = self._body(name, thickness / 2, "plate")
        g = b.add_geom(name=f"{name}_plate", type=mujoco.mjtGeom.mjGEOM_BOX, size=[width / 2, width / 2, thickness / 2], mass=mass)
        g.rgba = [0.7, 0.5, 0.3, 1]
        self._collide(g)
        self.tools[name].geoms["plate"] = [f"{name}_plate"]
        return self.tools[name]

    def add_hand(self, name: str = "hand", *, length: float = 0.18, left: bool = False, mass: float = 0.4) -> Tool:
        """A hand `length` metres from wrist to middle fingertip (see the module's docs)."""
        _positive(length=length, mass=mass)
        mujoco = _mujoco()
        s = length / 0.18
        side = -1.0 if left else 1.0
        ray_r = 0.012 * s
        b = self._body(name, ray_r + PALM_TRAVEL, "hand")
        tool = self.tools[name]
        palm_len = 0.09 * s
        # The tool's origin is the middle of the hand, wrist to middle fingertip (a press at a
        # point lays the whole hand around it); the palm's centre lies this far behind it.
        mid = 0.045 * s
        rays = [0.0315, 0.0105, -0.0105, -0.0315]  # index, middle, ring, pinkie (x, right hand)
        finger_len = {"index": 0.072, "middle": 0.08, "ring": 0.075, "pinkie": 0.06, "thumb": 0.062}
        finger_r = {"index": 0.0085, "middle": 0.009, "ring": 0.0085, "pinkie": 0.0075, "thumb": 0.0105}
        # A core, not touching anything, keeps the hand's mass and inertia where its palm is.
        core = b.add_geom(name=f"{name}_core", type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.035 * s, 0.045 * s, 0.006 * s])
        core.pos = [0, -mid, 0.01 * s]
        core.mass = mass * 0.5
        core.contype = 0
        core.conaffinity = 0
        tool.geoms["palm"] = []

        def pad(body_name: str, fromto, finger: Optional[str]):
            # A palm pad on a spring along the hand's z: pressed onto a curved link, each pad
            # gives way as far as the surface under it needs (a bed of springs, as flesh is).
            pad = b.add_body(name=body_name)
            pad.gravcomp = 1.0
            j = pad.add_joint(name=body_name, type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[0, 0, 1])
            j.stiffness = [PALM_STIFFNESS, 0.0, 0.0]
            j.springref = -PALM_TRAVEL
            j.damping = [2.0, 0.0, 0.0]
            j.range = [-PALM_TRAVEL, 0.0]
            j.limited = mujoco.mjtLimited.mjLIMITED_TRUE
            g = pad.add_geom(name=body_name, type=mujoco.mjtGeom.mjGEOM_CAPSULE, fromto=fromto, size=[ray_r, 0, 0], mass=mass * 0.06)
            g.rgba = [0.95, 0.75, 0.6, 1]
            g.solref = list(FLESH_SOLREF)
            g.solimp = list(FLESH_SOLIMP)
            g.priority = 2
            self._collide(g)
            tool.geoms["palm"].append(g.name)
            return pad

        for finger, x in zip(("index", "middle", "ring", "pinkie"), rays):
            x *= s * side
            ray = pad(f"{name}_{finger}_palm", [x, -palm_len / 2 - mid, 0, x, palm_len / 2 - mid, 0], finger)
            self._finger(tool, ray, finger, [x, palm_len / 2 + ray_r - mid, 0], 0.0, finger_len[finger] * s, finger_r[finger] * s, mass)
        # The thenar pad at the thumb's root, and the thumb turned out from it by 50 degrees.
        thenar = pad(f"{name}_thenar", [side * 0.03 * s, -0.04 * s - mid, 0, side * 0.044 * s, -0.015 * s - mid, 0], None)
        thumb_base = [side * 0.044 * s, -0.015 * s - mid, 0]
        self._finger(tool, thenar, "thumb", thumb_base, -side * np.radians(50), finger_len["thumb"] * s, finger_r["thumb"] * s, mass)
        return tool

    def _finger(self, tool: Tool, parent, finger: str, base, yaw: float, length: float, radius: float, mass: float) -> None:
        mujoco = _mujoco()
        name = tool.name
        prox_len, dist_len = 0.55 * length, 0.45 * length - radius
        prox = parent.add_body(name=f"{name}_{finger}_1", pos=base, quat=[np.cos(yaw / 2), 0, 0, np.sin(yaw / 2)])
        dist = prox.add_body(name=f"{name}_{finger}_2", pos=[0, prox_len, 0])
        prox.gravcomp = dist.gravcomp = 1.0
        geoms = []
        for k, (body, seg) in enumerate(((prox, prox_len), (dist, dist_len))):
            j = body.add_joint(name=f"{name}_{finger}_{k + 1}", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[-1, 0, 0])
            j.range = self._angles(-0.6, 1.6)
            j.limited = mujoco.mjtLimited.mjLIMITED_TRUE
            j.damping = [0.02, 0.0, 0.0]
            g = body.add_geom(
                name=f"{name}_{finger}_{k + 1}",
                type=mujoco.mjtGeom.mjGEOM_CAPSULE,
                fromto=[0, 0, 0, 0, seg, 0],
                size=[radius, 0, 0],
                mass=mass * 0.03,
            )
            g.rgba = [0.95, 0.75, 0.6, 1]
            g.solref = list(FLESH_SOLREF)
            g.solimp = list(FLESH_SOLIMP)
            g.priority = 2
            self._collide(g)
            geoms.append(g.name)
            a = self.spec.add_actuator(name=f"{name}_{finger}_{k + 1}", target=j.name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
            a.set_to_motor()
        tool.geoms[finger] = geoms
        tool.actuators[finger] = (f"{name}_{finger}_1", f"{name}_{finger}_2")
        tool.lever[finger] = (0.5 * length, 0.25 * length)

    # --- running --------------------------------------------------------------------------

    def _angles(self, *radians: float) -> List[float]:
        """Joint angles in the spec's unit (MJCF's default is degrees)."""
        return [float(np.degrees(r)) if self.spec.compiler.degree else r for r in radians]

    def _collide(self, geom) -> None:
        geom.contype = TOOL_CONTYPE
        geom.conaffinity = TOOL_CONAFFINITY

    def bind(self, model, data) -> None:
        """Ids in the compiled model; every tool parked."""
        mujoco = _mujoco()
        self.model, self.data = model, data
        for tool in self.tools.values():
            tool.body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, tool.name)
            j = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, f"{tool.name}_free")
            tool.qpos, tool.qvel = int(model.jnt_qposadr[j]), int(model.jnt_dofadr[j])
            # The joints inside the tool (a hand's pads and fingers), set back to rest whenever
            # the tool is placed: a finger still flexed from the last press must not start
            # inside the skin.
            inside = [
                k for k in range(model.njnt)
                if k != j and _descends(model, int(model.jnt_bodyid[k]), tool.body)
            ]
            tool.joints = [(int(model.jnt_qposadr[k]), int(model.jnt_dofadr[k])) for k in inside]
            tool.mass = float(model.body_subtreemass[tool.body])
            # The body's own principal inertia, and its children's mass about 5 cm away (a
            # hand's fingers): the springs' gains scale with it, axis by axis.
            tool.inertia = np.maximum(model.body_inertia[tool.body], 1e-7) + (tool.mass - float(model.body_mass[tool.body])) * 0.05**2
            for finger, (a1, a2) in tool.actuators.items():
                tool.ctrl[finger] = (
                    mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, a1),
                    mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, a2),
                )
            for part, names in tool.geoms.items():
                tool.geom_ids[part] = np.array([mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, n) for n in names])
            self._place(tool, tool.park, np.array([1.0, 0, 0, 0]))
        self._limits()
        mujoco.mj_forward(model, data)
        self._placed: Dict[str, Action] = {}
        self._bodies = {
            a.body: self._body_id(a.body) for a in self.actions if a.body is not None
        }
        # Actions scripted before the model was known, checked against it now.
        for a in self.actions:
            self._check_force(a)

    def _limits(self) -> None:
        """Each tool's force limit on the model's skin: the least force at which any of its
        geoms sinks as deep as a skin allows into any geom that carries a skin (`holding_force`)."""
        model = self.model
        skin = skin_geoms(model)
        for tool in self.tools.values():
            tool.limit, tool.limit_depth = np.inf, 0.0
            for g in (g for ids in tool.geom_ids.values() for g in ids):
                for s in skin:
                    if collide(model, int(g), int(s)):
                        force, depth = holding_force(model, tool.mass, int(g), int(s))
                        if force < tool.limit:
                            tool.limit, tool.limit_depth = force, depth

    def force_limit(self, tool: str) -> float:
        """The largest force (N) `tool` may press the model's skin with (after `bind`; infinite
        with no skin): the force at which it sinks into the skin as deep as a skin gives, MuJoCo's
        soft contact at rest (`bridge.holding_force`). It grows with the tool's mass (and the
        cover's stiffness), not its size."""
        if tool not in self.tools:
            raise UnknownNameError(f"no tool {tool!r} (tools: {sorted(self.tools)})")
        if self.model is None:
            raise NotReadyError("Kit.bind(model, data) first")
        return float(self.tools[tool].limit)

    def _check_force(self, a: Action) -> None:
        tool = self.tools[a.tool]
        if a.force > tool.limit:
            raise ArrayError(
                f"{a.tool}: force = {a.force:g} N at {a.start:g} s: more than this scene holds; beyond "
                f"{tool.limit:.1f} N the {tool.kind} ({tool.mass:g} kg) sinks into the skin deeper than a skin gives "
                f"({tool.limit_depth * 1e3:g} mm), and further on through the link. Press with {tool.limit:.1f} N at "
                "most, or give the tool more mass (the limit grows with it)"
            )

    def _body_id(self, name: str) -> int:
        mujoco = _mujoco()
        b = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_BODY, name)
        if b < 0:
            raise UnknownNameError(f"no body {name!r} in the model")
        return int(b)

    def add(self, action: Action) -> Action:
        """Adds an action to the script, checked: a known tool, finite numbers, a force of 0 N
        or more and within what the scene holds (`force_limit`; checked by `bind` for actions
        added before it), a ramp up and down within the duration, a hand's fingers by name, no
        other action of the same tool at the same time, nothing in the simulation's past."""
        a = action
        if a.tool not in self.tools:
            raise UnknownNameError(f"no tool {a.tool!r} (tools: {sorted(self.tools)})")
        a.path = np.atleast_2d(np.asarray(a.path, dtype=np.float64))
        normal = np.atleast_2d(np.asarray(a.normal, dtype=np.float64))
        if a.path.ndim != 2 or a.path.shape[1] != 3 or normal.shape[1] != 3 or len(normal) not in (1, len(a.path)):
            raise ArrayError("path: (P, 3) world points; normal: (3,) or (P, 3)")
        lengths = np.linalg.norm(normal, axis=1)
        if not (np.all(np.isfinite(a.path)) and np.all(np.isfinite(normal)) and np.all(lengths > 1e-9)):
            raise ArrayError(f"{a.tool}: the path and normals must be finite, each normal of non-zero length")
        a.normal = normal / lengths[:, None]
        for name, value, ok, expected in (
            ("force", a.force, a.force >= 0.0, "newtons, 0 or more"),
            ("start", a.start, a.start >= 0.0, "seconds, 0 or more"),
            ("duration", a.duration, a.duration > 0.0, "seconds, more than 0"),
            ("ramp", a.ramp, 0.0 < a.ramp <= a.duration / 2, "seconds, more than 0 and at most half the duration"),
            ("yaw", a.yaw, True, "radians"),
        ):
            if not (np.isfinite(value) and ok):
                raise ArrayError(f"{a.tool}: {name} = {value}: {expected}")
        if a.fingers is not None:
            if self.tools[a.tool].kind != "hand":
                raise ArrayError(f"{a.tool}: fingers are for a hand, this is a {self.tools[a.tool].kind}")
            if isinstance(a.fingers, str) or not all(f in FINGERS for f in a.fingers):
                raise ArrayError(f"{a.tool}: fingers = {a.fingers!r}: a list of {', '.join(FINGERS)}")
            a.fingers = list(a.fingers)
        for b in self.actions:
            if b.tool == a.tool and a.start < b.start + b.duration and b.start < a.start + a.duration:
                raise ArrayError(
                    f"{a.tool}: {a.start:g}-{a.start + a.duration:g} s overlaps its action at "
                    f"{b.start:g}-{b.start + b.duration:g} s (one action at a time per tool)"
                )
        if self.data is not None and a.start < self.data.time:
            raise ArrayError(f"{a.tool}: starts at {a.start:g} s, the simulation is at {self.data.time:g} s already")
        if self.model is not None:
            self._check_force(a)
        if a.body is not None and self.model is not None:
            self._bodies[a.body] = self._body_id(a.body)
        self.actions.append(a)
        mine = self._by_tool.setdefault(a.tool, [])
        mine.append(a)
        mine.sort(key=lambda b: b.start)
        self._next[a.tool] = 0
        return a

    def press(self, tool: str, point, normal, force: float, start: float, duration: float, **kw) -> Action:
        """A press at `point` (world) along `normal` with `force` newtons."""
        return self.add(Action(tool, np.asarray(point, dtype=np.float64), np.asarray(normal, dtype=np.float64), force, start, duration, **kw))

    def grasp(self, tool: str, point, normal, force: float, start: float, duration: float, *, axis, **kw) -> Action:
        """A hand closed around a link: pressed at `point` with `normal`, its fingers across
        `axis` (the link's long axis, world; the hand's fingers point along normal x axis, so
        they wrap around the link), every finger flexed onto it."""
        n = np.asarray(normal, dtype=np.float64)
        n = n / np.linalg.norm(n)
        across = np.cross(n, np.asarray(axis, dtype=np.float64))
        if np.linalg.norm(across) < 1e-9:
            raise ArrayError("grasp: the axis lies along the normal; give the link's long axis")
        across /= np.linalg.norm(across)
        # The yaw that turns the hand's fingers (its y at yaw 0) onto `across`.
        rot = np.zeros(9)
        _mujoco().mju_quat2Mat(rot, _quat_from_z(n, 0.0))
        y0 = rot.reshape(3, 3)[:, 1]
        yaw = float(np.arctan2(np.cross(y0, across) @ n, y0 @ across))
        return self.press(tool, point, n, force, start, duration, yaw=yaw, **kw)

    def slide(self, tool: str, path, normal, force: float, start: float, duration: float, **kw) -> Action:
        """A press moving along `path` (world points)."""
        return self.add(Action(tool, np.asarray(path, dtype=np.float64), np.asarray(normal, dtype=np.float64), force, start, duration, **kw))

    def random_presses(
        self,
        points,
        normals,
        count: int,
        *,
        seed: int = 1,
        start: float = 1.5,
        duration: float = 1.0,
        gap: float = 0.6,
        yaws: Tuple[float, float] = (-np.pi, np.pi),
        forces: Optional[Dict[str, Tuple[float, float]]] = None,
    ) -> List[Action]:
        """`count` presses one after the other, each tool of the kit in turn, at random points of
        `points` (world, each with its outward `normals`), random forces (newtons, per kind:
        hand 8-20, bar 5-20, sphere and plate 3-20 by default), yaws in `yaws` (turned half a turn at
        random) and, for a hand, a random set of fingers (each pressing with probability 0.7).
        Deterministic for `seed`; the skin's first `start` seconds untouched (its baseline)."""
        rng = np.random.default_rng(seed)
        ranges = {"hand": (8.0, 20.0), "bar": (5.0, 20.0), "sphere": (3.0, 20.0), "plate": (3.0, 20.0)}
        ranges.update(forces or {})
        points = np.asarray(points, dtype=np.float64)
        normals = np.asarray(normals, dtype=np.float64)
        if len(points) == 0 or points.shape != normals.shape:
            raise ArrayError("points and normals: (N, 3) each, N > 0")
        names = sorted(self.tools, key=lambda n: ("hand", "bar", "sphere", "plate").index(self.tools[n].kind))
        out = []
        t = start
        for k in range(count):
            tool = self.tools[names[k % len(names)]]
            i = int(rng.integers(len(points)))
            lo, hi = ranges[tool.kind]
            force = float(rng.uniform(lo, hi))
            yaw = float(rng.uniform(*yaws)) + (np.pi if rng.random() < 0.5 else 0.0)
            fingers = None
            if tool.kind == "hand":
                fingers = [f for f in FINGERS if rng.random() < 0.7]
            out.append(self.press(tool.name, points[i], normals[i], force, t, duration, yaw=yaw, fingers=fingers))
            t += duration + gap
        return out

    def active(self, tool: str, t: float) -> Optional[Action]:
        """The tool's action under way at time t, if any."""
        # The tool's actions never overlap (`add` checks): the first not yet over is the only
        # candidate, and one over stays over as the clock runs on.
        actions = self._by_tool.get(tool, [])
        k = self._next.get(tool, 0)
        if k > 0 and t < actions[k - 1].start + actions[k - 1].duration:
            k = 0  # the clock went back (a reset): search from the start
        while k < len(actions) and t >= actions[k].start + actions[k].duration:
            k += 1
        self._next[tool] = k
        if k < len(actions) and actions[k].start <= t:
            return actions[k]
        return None

    def _place(self, tool: Tool, pos, quat) -> None:
        d = self.data
        d.qpos[tool.qpos : tool.qpos + 3] = pos
        d.qpos[tool.qpos + 3 : tool.qpos + 7] = quat
        d.qvel[tool.qvel : tool.qvel + 6] = 0.0
        for qpos, dof in tool.joints:
            d.qpos[qpos] = self.model.qpos0[qpos]
            d.qvel[dof] = 0.0

    def control(self, loop=None) -> None:
        """Sets every tool's wrench and servos for the step about to run (a `SkinLoop` control)."""
        if self.data is None:
            raise NotReadyError("Kit.bind(model, data) first")
        mujoco = _mujoco()
        d = self.data
        t = float(d.time)
        for tool in self.tools.values():
            a = self.active(tool.name, t)
            if a is None:
                if tool.name in self._placed:
                    # Back to its place, still: held against gravity and with nothing near it,
                    # a parked tool stays there with no wrench at all.
                    del self._placed[tool.name]
                    self._place(tool, tool.park, np.array([1.0, 0, 0, 0]))
                    d.xfrc_applied[tool.body] = 0.0
                    mujoco.mj_forward(self.model, d)
                continue
            normal = a.normal_at(t)
            point = a.target(t)
            carrier = None
            if a.body is not None:
                # On a moving link: the path, the normal and the yaw are the link's, and the
                # tool is damped relative to the link's point under it.
                b = self._bodies[a.body]
                rot = d.xmat[b].reshape(3, 3)
                normal, point = rot @ normal, d.xpos[b] + rot @ point
                local = np.zeros(4)
                mujoco.mju_mulQuat(local, d.xquat[b], self._quat(a, a.normal_at(t)))
                quat = local
                carrier = (b, point)
            else:
                quat = self._quat(a, normal)
            hover = point + normal * (tool.reach + 0.004)
            if self._placed.get(tool.name) is not a:
                # A new action starts above its first point, still, fingers set; the pose is
                # computed again so the first step's spring pulls from there.
                self._placed[tool.name] = a
                self._place(tool, hover, quat)
                mujoco.mj_forward(self.model, d)
            force = a.force_at(t)
            for finger, (c1, c2) in tool.ctrl.items():
                if a.fingers is None or finger in a.fingers:
                    # At least a light touch while the force ramps, so the finger settles.
                    f = FINGER_SHARE * max(force, 1.0)
                    d.ctrl[c1], d.ctrl[c2] = (f * tool.lever[finger][0], f * tool.lever[finger][1])
                else:
                    d.ctrl[c1], d.ctrl[c2] = LIFT_TORQUE
            self._drive(tool, hover, quat, normal if force > 0 else None, force, hold_turn=not a.roll, carrier=carrier)

    def _quat(self, a: Action, normal: np.ndarray) -> np.ndarray:
        # One orientation per action unless its normal follows the path.
        if len(a.normal) == 1:
            if a._quat is None:
                a._quat = _quat_from_z(normal, a.yaw)
            return a._quat
        return _quat_from_z(normal, a.yaw)

    def _drive(self, tool: Tool, pos, quat, normal, force, *, hold_turn: bool, carrier=None) -> None:
        mujoco = _mujoco()
        d = self.data
        w = 2 * np.pi * 8.0  # the spring's natural frequency, rad/s
        vel = np.zeros(6)
        mujoco.mj_objectVelocity(self.model, d, mujoco.mjtObj.mjOBJ_BODY, tool.body, vel, 0)
        omega, v = vel[:3], vel[3:]
        if carrier is not None:
            # Velocities relative to the link the tool presses (its point under the tool).
            b, point = carrier
            link = np.zeros(6)
            mujoco.mj_objectVelocity(self.model, d, mujoco.mjtObj.mjOBJ_BODY, b, link, 0)
            omega = omega - link[:3]
            v = v - (link[3:] + np.cross(link[:3], point - d.xpos[b]))
        x = d.xpos[tool.body]
        f = tool.mass * (w * w * (pos - x) - 2 * w * v)
        if normal is not None:
            # Along the normal: the force, damped; across it: the spring.
            f -= normal * (normal @ f)
            f += -force * normal - normal * (2 * w * tool.mass * (normal @ v))
        # About the body's principal axes (its inertial frame), each with its own inertia.
        rot = d.ximat[tool.body].reshape(3, 3)
        omega_b = rot.T @ omega
        if hold_turn:
            q = d.xquat[tool.body]
            dq, err = np.zeros(4), np.zeros(3)
            mujoco.mju_mulQuat(dq, quat, np.array([q[0], -q[1], -q[2], -q[3]]))
            mujoco.mju_quat2Vel(err, dq, 1.0)
            torque_b = tool.inertia * (w * w * (rot.T @ err) - 2 * w * omega_b)
        else:
            torque_b = -tool.inertia * 0.1 * w * omega_b
        torque = rot @ torque_b
        d.xfrc_applied[tool.body, :3] = f
        d.xfrc_applied[tool.body, 3:] = torque

    def touching(self, tool: str, body: int, *, distal: bool = False) -> Dict[str, float]:
        """The normal force (N) each part of `tool` ("palm", a finger, "ball", "rod") puts on
        `body` now; `distal`: a finger's distal phalanx only (its pad, which a lifted finger
        never presses)."""
        mujoco = _mujoco()
        model, d = self.model, self.data
        t = self.tools[tool]
        out = {part: 0.0 for part in t.geom_ids}
        f = np.zeros(6)
        for i in range(d.ncon):
            c = d.contact[i]
            if c.efc_address < 0:
                continue
            for mine, other in ((c.geom1, c.geom2), (c.geom2, c.geom1)):
                if model.geom_bodyid[other] != body:
                    continue
                for part, ids in t.geom_ids.items():
                    if distal and part in FINGERS:
                        ids = ids[1:]
                    if mine in ids:
                        mujoco.mj_contactForce(model, d, i, f)
                        out[part] += float(f[0])
        return out
