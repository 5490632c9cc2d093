"""The skin on a MuJoCo model: where each taxel sits, what it reads.

`SkinBridge.attach` adds to a model's spec, for each link of the layout:

- a sensor surface: the link's skin triangulated (the layout's triangles, else the tactile map's)
  and cut finer (`spacing_mm`, 3 mm by default), a non-colliding mesh on the link's body, and
  MuJoCo's `tactile` sensor on it, which reports at every vertex how deep another geom presses
  it (computed once per skin frame: the sensor's `interval`, on the simulation's clock);
- what is touched (`contact`): "hull", the convex hull of the taxels and of the same points 5 mm
  under them (the cover as a solid, for a bare layout or a robot model without collision geoms
  there; a hull spans a concave link's hollows), or "model", the body's own geoms.

MuJoCo's tactile sensor sees primitive geoms and meshes with a signed distance field: `attach`
asks MuJoCo for one on every mesh of the model that can touch (`needsdf`).

Each skin frame (`SkinBridge.frame`) then turns the simulation into readings:

1. the force of every contact on the link's body (the cover and the body's own geoms;
   `mj_contactForce`) is spread over the surface in proportion to each vertex's depth
   times its area (a Winkler bed: the pressure follows how far the cover is pressed in, the total
   is MuJoCo's force); a contact that presses no vertex (a touch between the samples) puts its
   force on the vertex nearest to it if that lies within the kernel's reach, and a contact
   farther from the skin (the underside of a link, where there is none) is not felt;
2. the cover carries that load to each taxel (Boussinesq, `surface.boussinesq`);
3. `Response` makes counts of the stress: gain, saturation, rest, noise, dead taxels, modules lost.
"""

from __future__ import annotations

import functools
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Dict, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from .. import _skin
from .._errors import ArrayError, NotReadyError, UnknownNameError
from .response import Response
from .surface import KERNEL_REACH, Kernel, Surface, boussinesq, sample_surface

_PathLike = Union[str, Path]

#: How far under the taxels the "hull" contact surface reaches, metres; also how deep anything may
#: press into a link's skin (`allowed_depth`), whatever carries it: a real cover gives no more, and
#: a tool sunk deeper images a wider touch than any cover could.
HULL_DEPTH = 0.005

#: The "hull" cover's contact softness (MuJoCo's solref and solimp): softer than MuJoCo's default
#: (0.02 s; 0.9 to 0.95 over 1 mm), as a skin's foam and silicone are.
COVER_SOLREF = (0.03, 1.0)
COVER_SOLIMP = (0.5, 0.95, 0.005, 0.5, 2.0)

#: The timesteps a scene with a skin runs at, seconds. Above the largest, MuJoCo softens the cover
#: (it keeps every contact's time constant at two steps or more) and the kit's tools, held by
#: 8 Hz springs, no longer settle; below the smallest, a 20 Hz skin frame takes more than 5,000
#: steps (most likely milliseconds given for seconds). MuJoCo's default is 0.002.
MIN_TIMESTEP = 1e-5
MAX_TIMESTEP = COVER_SOLREF[0] / 2


@functools.cache
def _mujoco():
    """MuJoCo's module, checked once (the loop and the tools ask for it at every step)."""
    try:
        import mujoco
    except ImportError as e:  # pragma: no cover - said to the user
        raise ImportError("skin.sim needs MuJoCo: pip install mujoco (Python 3.11 or later)") from e
    if int(mujoco.__version__.split(".")[0]) < 4:  # pragma: no cover - said to the user
        raise ImportError(f"skin.sim needs MuJoCo 4 (its tactile sensor); this is {mujoco.__version__}: pip install -U mujoco")
    return mujoco


@dataclass
class _Link:
    name: str
    body: str
    ids: np.ndarray
    positions: np.ndarray
    surface: Surface
    kernel: Kernel
    # How far from the nearest taxel a contact still loads the skin, metres.
    reach: float
    # Set by bind():
    body_id: int = -1
    adr: int = -1
    touched: set = field(default_factory=set)


@dataclass
class SimFrame:
    """One frame of the simulated skin, as the buses would deliver it."""

    #: Seconds, the simulation's clock.
    time: float
    #: Per link (layout order), raw counts, (N_link,) float32.
    readings: List[np.ndarray]
    #: With a bus map: (S,) counts in bus-map slot order; else None.
    slots: Optional[np.ndarray]
    #: Modules whose data did not arrive in this frame, (interface, address).
    missing: List[Tuple[str, int]]
    #: Per link, the stress at each taxel, pascals (before the response).
    stress: List[np.ndarray]

    def push(self, session) -> list:
        """Through a `skin.Session`: by the buses' path when the session has a bus map (missing
        modules reported as a CAN log's are), else as one reading per taxel. Returns its events."""
        if self.slots is not None:
            return session.push_bus(self.slots, self.time, self.missing)
        return session.push(self.readings, self.time)


class SkinBridge:
    """A skin layout simulated on a MuJoCo model (see the module's docs)."""

    def __init__(
        self,
        layout,
        *,
        busmap=None,
        response: Optional[Mapping] = None,
        polarity: str = "rising",
        spacing_mm: float = 3.0,
        baseline_frames: int = 20,
    ) -> None:
        """`layout`: a `skin.Layout` or a path to any layout file `skin` reads; `busmap`: a
        `skin.BusMap` or its path (frames then follow the buses, missing modules included);
        `response`: `[sim]` keys (checked as a configuration's, over the defaults);
        `baseline_frames`: the session's `[baseline] frames` (missing modules wait for them)."""
        if isinstance(layout, (str, Path)):
            layout = _skin.read_layout(layout)
        if isinstance(busmap, (str, Path)):
            busmap = _skin.BusMap.read(busmap)
        if not (1.0 <= spacing_mm <= 50.0):
            raise ArrayError(f"spacing_mm = {spacing_mm}: millimetres from 1 to 50")
        if polarity not in ("rising", "falling"):
            raise ArrayError(f'polarity = {polarity!r}: "rising" or "falling"')
        self.layout = layout
        self.busmap = busmap
        # A table from Python is checked as a configuration file's is, over the defaults.
        cfg = _skin.read_sim_config(None, dict(response) if response is not None else None)
        self.config = cfg
        self.spacing = spacing_mm * 1e-3
        self.cover = float(cfg["cover_mm"]) * 1e-3
        self.frame_rate = float(cfg["frame_rate_hz"])
        self._links: List[_Link] = []
        for link in layout.links:
            faces = link.faces
            if faces is None:
                tmap = _skin.flatten(link, triangulate=True)
                faces = np.asarray(tmap.faces)
                if not np.array_equal(tmap.ids, link.ids):
                    if len(set(np.asarray(link.ids).tolist())) != len(link):
                        raise ArrayError(f"link {link.name!r}: its tactile map orders taxels otherwise and ids repeat; give the layout its triangles")
                    faces = _order_of(tmap.ids, link.ids)[faces]
            surface = sample_surface(link.positions, faces, self.spacing)
            self._links.append(
                _Link(
                    name=link.name,
                    body=link.name,
                    ids=np.asarray(link.ids),
                    positions=np.asarray(link.positions),
                    surface=surface,
                    kernel=boussinesq(link.positions, surface.points, self.cover, surface.areas),
                    reach=KERNEL_REACH * self.cover + _farthest_from_taxels(surface.points, link.positions),
                )
            )
        self.response = Response(
            [l.ids for l in self._links], cfg, busmap=busmap, polarity=polarity, baseline_frames=baseline_frames
        )
        self._model = None
        self._steps_per_frame = 0
        self._period = 0.0
        self._contact = "hull"

    @classmethod
    def from_config(cls, path: _PathLike, *, spacing_mm: float = 3.0) -> "SkinBridge":
        """The layout, bus map, polarity and `[sim]` response of a run configuration (`skin run`'s
        run.toml; paths in it relative to it)."""
        path = Path(path)
        response = _skin.read_sim_config(path)  # checks the whole file, names what is wrong
        with open(path, "rb") as f:
            table = tomllib.load(f)
        base = path.parent
        busmap = table.get("busmap")
        polarity = table.get("baseline", {}).get("polarity", "rising")
        frames = table.get("baseline", {}).get("frames", 20)
        return cls(
            base / table["layout"],
            busmap=base / busmap if busmap else None,
            response=response,
            polarity=polarity,
            spacing_mm=spacing_mm,
            baseline_frames=frames,
        )

    @property
    def links(self) -> List[str]:
        return [l.name for l in self._links]

    def surface(self, link: Union[int, str]) -> Surface:
        """The points MuJoCo samples on a link (its frame, metres)."""
        return self._links[self._index(link)].surface

    def attach(
        self,
        spec,
        *,
        bodies: Optional[Mapping[str, str]] = None,
        contact: str = "hull",
    ) -> None:
        """Adds the skin to `spec` (a `mujoco.MjSpec`, before `compile`): each link on the body of
        its name, or `bodies[link]`. A link with no such body is an error naming both."""
        mujoco = _mujoco()
        if contact not in ("hull", "model"):
            raise ArrayError(f'contact = {contact!r}: "hull" or "model"')
        bodies = dict(bodies or {})
        unknown = set(bodies) - set(self.links)
        if unknown:
            raise ArrayError(f"bodies names no link of the layout: {sorted(unknown)} (links: {self.links})")
        dt = check_timestep(spec.option.timestep, "the spec's option.timestep")
        steps = int(round(1.0 / (self.frame_rate * dt)))
        if steps < 1 or abs(steps * dt * self.frame_rate - 1.0) > 1e-6:
            raise ArrayError(
                f"frame_rate_hz = {self.frame_rate}: a skin frame must last a whole number of MuJoCo "
                f"steps (timestep {dt} s); e.g. {1.0 / (max(steps, 1) * dt):g} Hz"
            )
        # Everything checked before the spec changes: a refused call leaves it as it was.
        placed = {}
        for link in self._links:
            name = bodies.get(link.name, link.name)
            if spec.body(name) is None:
                names = [b.name for b in spec.bodies if b.name][:12]
                raise ArrayError(
                    f"link {link.name!r}: the model has no body {name!r} (bodies: {', '.join(names)}); "
                    "name it in bodies={link: body}"
                )
            if name in placed:
                raise ArrayError(f"links {placed[name]!r} and {link.name!r} on one body {name!r}: give each link its own body")
            placed[name] = link.name
            if spec.mesh(f"skin_{link.name}_surface") is not None:
                raise ArrayError(f"link {link.name!r}: this spec has its skin already (attach once)")
            if contact == "model" and not any(g.contype or g.conaffinity for g in spec.body(name).geoms):
                raise ArrayError(
                    f"link {link.name!r}: body {name!r} has no geom that collides, so nothing can touch its "
                    'skin with contact="model"; give it collision geoms or use contact="hull"'
                )
        # The tactile sensor sees a mesh that touches it only through the mesh's signed distance
        # field; primitives need none.
        touching = {
            g.meshname
            for g in spec.geoms
            if g.type == mujoco.mjtGeom.mjGEOM_MESH and (g.contype or g.conaffinity)
        }
        for mesh in spec.meshes:
            if mesh.name in touching and not mesh.name.startswith("skin_"):
                mesh.needsdf = 1
        self._steps_per_frame = steps
        self._period = steps * dt
        self._contact = contact
        for layout_link, link in zip(self.layout.links, self._links):
            link.body = bodies.get(link.name, link.name)
            body = spec.body(link.body)
            tag = f"skin_{link.name}"
            surf = spec.add_mesh(name=f"{tag}_surface")
            surf.uservert = link.surface.points.ravel().tolist()
            surf.userface = link.surface.faces.ravel().tolist()
            surf.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL
            g = body.add_geom(name=f"{tag}_surface")
            g.type = mujoco.mjtGeom.mjGEOM_MESH
            g.meshname = f"{tag}_surface"
            g.contype = 0
            g.conaffinity = 0
            g.mass = 0.0
            g.group = 4
            g.rgba = [0.9, 0.6, 0.3, 0.4]
            if contact == "hull":
                inner = link.positions - HULL_DEPTH * np.asarray(layout_link.normals)
                hull = spec.add_mesh(name=f"{tag}_cover")
                hull.uservert = np.vstack([link.positions, inner]).ravel().tolist()
                c = body.add_geom(name=f"{tag}_cover")
                c.type = mujoco.mjtGeom.mjGEOM_MESH
                c.meshname = f"{tag}_cover"
                c.mass = 0.0
                c.rgba = [0.8, 0.8, 0.75, 1.0]
                # The cover is soft: a rigid object sinks into it (COVER_SOLREF / _SOLIMP win
                # over the other geom's unless that one has a higher priority, as a hand's
                # flesh does).
                c.priority = 1
                c.solref = list(COVER_SOLREF)
                c.solimp = list(COVER_SOLIMP)
            s = spec.add_sensor(name=tag)
            s.type = mujoco.mjtSensor.mjSENS_TACTILE
            s.objtype = mujoco.mjtObj.mjOBJ_MESH
            s.objname = f"{tag}_surface"
            s.reftype = mujoco.mjtObj.mjOBJ_GEOM
            s.refname = f"{tag}_surface"
            # Computed once per skin frame, at the step that starts it (frames count steps).
            # The phase half a step early: the clock adds up `timestep` in floating point, and a
            # frame due at 2.25 s must not wait for a clock that reads 2.2499999 to pass it.
            s.nsample = 1
            s.interval = [steps * dt, -0.5 * dt]

    def bind(self, model) -> None:
        """The compiled model's ids and sensor addresses; call once after `spec.compile()`
        (`SkinLoop` does)."""
        mujoco = _mujoco()
        dt = check_timestep(model.opt.timestep, "the model's opt.timestep")
        steps = int(round(self._period / dt)) if self._period else 0
        if steps < 1 or abs(steps * dt - self._period) > 1e-9:
            raise ArrayError(
                f"the model's timestep is {dt} s but the skin was attached for {self._period} s frames "
                f"({self.frame_rate:g} Hz): a skin frame must last a whole number of MuJoCo steps; "
                "attach the skin with the timestep the model runs at"
            )
        for link in self._links:
            sid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SENSOR, f"skin_{link.name}")
            if sid < 0:
                raise ArrayError(f"link {link.name!r}: the model has no skin sensor: attach() before compile()")
            link.adr = int(model.sensor_adr[sid])
            if model.sensor_dim[sid] != 3 * len(link.surface.points):
                raise ArrayError(f"link {link.name!r}: its sensor has {model.sensor_dim[sid] // 3} points, not {len(link.surface.points)}")
            link.body_id = int(mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, link.body))
            # The cover and the robot's own geoms on the body: where the robot's geoms lie right
            # under the skin they take part of a press; a contact away from the skin (the
            # link's underside) is dropped by its distance (`stress`).
            link.touched = {int(g) for g in np.flatnonzero(model.geom_bodyid == link.body_id)}
        self._model = model
        self._steps_per_frame = steps
        self._force = np.zeros(6)
        # Each geom's link (-1: on none), and how deep each pair may press (`too_deep`).
        self._geom_link = np.full(model.ngeom, -1, dtype=np.int64)
        for k, link in enumerate(self._links):
            self._geom_link[list(link.touched)] = k
        self._allowed: Dict[Tuple[int, int], float] = {}

    def too_deep(self, data) -> List[Tuple[int, int, float, float, np.ndarray]]:
        """The geoms pressed into a link's skin deeper than it allows (`allowed_depth`) at the last
        step: per link and geom, the deepest contact's (link index, geom id, depth m, allowed depth
        m, contact normal out of the link in the link's frame). A press the scene cannot hold."""
        n = data.ncon
        if n == 0:
            return []
        con = data.contact
        deep = np.flatnonzero(con.dist < -HULL_DEPTH)
        found: Dict[Tuple[int, int], Tuple[float, float, np.ndarray]] = {}
        for i in deep:
            g1, g2 = (int(g) for g in con.geom[i])
            # (A flex's side has no geom: -1.)
            if g1 >= 0 and g2 >= 0 and self._geom_link[g1] >= 0:
                mine, other, outward = g1, g2, 1.0  # MuJoCo's normal points from geom1 to geom2
            elif g1 >= 0 and g2 >= 0 and self._geom_link[g2] >= 0:
                mine, other, outward = g2, g1, -1.0
            else:
                continue
            allowed = self._allowed.get((mine, other))
            if allowed is None:
                allowed = self._allowed[(mine, other)] = allowed_depth(self._model, mine, other)
            depth = -float(con.dist[i])
            key = (int(self._geom_link[mine]), other)
            if depth > allowed and (key not in found or depth > found[key][0]):
                found[key] = (depth, allowed, outward * np.array(con.frame[i, :3]))
        out = []
        for (k, other), (depth, allowed, normal) in found.items():
            rot = data.xmat[self._links[k].body_id].reshape(3, 3)
            out.append((k, other, depth, allowed, rot.T @ normal))
        return out

    def depth(self, data, link: Union[int, str] = 0) -> np.ndarray:
        """MuJoCo's tactile reading of a link's surface points (`surface(link).points`): how deep
        another geom presses each one, metres (as of the last skin frame; a copy)."""
        l = self._links[self._index(link)]
        return data.sensordata[l.adr : l.adr + len(l.surface.points)].copy()

    def owns_all_sensors(self, model) -> bool:
        """The model's sensors are this skin's and no others."""
        return int(model.nsensor) == len(self._links)

    @property
    def steps_per_frame(self) -> int:
        """MuJoCo steps in one skin frame."""
        return self._steps_per_frame

    def _pressing(self, data) -> List[Optional[Tuple[np.ndarray, np.ndarray, np.ndarray]]]:
        """Per link, the normal forces (N) of the contacts pressing its skin at the last step,
        where MuJoCo puts each and where each meets the skin's surface (its frame, metres); None
        where nothing presses it."""
        mujoco = _mujoco()
        model = self._model
        if model is None:
            raise NotReadyError("bind(model) first")
        body_of = model.geom_bodyid
        forces: List[List[Tuple[float, np.ndarray, np.ndarray]]] = [[] for _ in self._links]
        for i in range(data.ncon):
            c = data.contact[i]
            if c.efc_address < 0 or body_of[c.geom1] == body_of[c.geom2]:
                continue
            for k, link in enumerate(self._links):
                if c.geom1 in link.touched or c.geom2 in link.touched:
                    mujoco.mj_contactForce(model, data, i, self._force)
                    if self._force[0] > 0.0:
                        # MuJoCo's frame's first axis points from geom1 to geom2: out of the link
                        # when geom1 is the link's.
                        out_of = c.frame[:3] if c.geom1 in link.touched else -c.frame[:3]
                        forces[k].append((float(self._force[0]), np.array(c.pos), np.array(out_of) * abs(c.dist) / 2))
        out: List[Optional[Tuple[np.ndarray, np.ndarray, np.ndarray]]] = []
        for link, touching in zip(self._links, forces):
            if not touching:
                out.append(None)
                continue
            # Each contact in the link's frame; one farther from every taxel than the kernel
            # reaches past the samples around a taxel is not on the skin.
            rot = data.xmat[link.body_id].reshape(3, 3)
            origin = data.xpos[link.body_id]
            fn = np.array([f for f, _, _ in touching])
            local = (np.array([p for _, p, _ in touching]) - origin) @ rot
            # MuJoCo puts a contact halfway into the two geoms' overlap: on the skin's surface,
            # it lies half the overlap further into the link.
            surface = local - np.array([u for _, _, u in touching]) @ rot
            d2 = ((local[:, None, :] - link.positions[None]) ** 2).sum(axis=2).min(axis=1)
            on_skin = d2 <= link.reach**2
            out.append((fn[on_skin], local[on_skin], surface[on_skin]) if on_skin.any() else None)
        return out

    def stress(self, data) -> List[np.ndarray]:
        """Per link, the stress reaching each taxel (Pa), from the sensor and the contacts of the
        last step (`mj_step` leaves both as they were at the step's start)."""
        out = []
        for link, pressing in zip(self._links, self._pressing(data)):
            if pressing is None:
                # Nothing on the link: no stress at any of its taxels.
                out.append(np.zeros(len(link.ids)))
                continue
            fn, local, _ = pressing
            f = np.zeros(len(link.surface.points))
            depth = data.sensordata[link.adr : link.adr + len(link.surface.points)]
            load = depth * link.surface.areas
            s = load.sum()
            total = float(fn.sum())
            if s > 0.0:
                f = load * (total / s)
            else:
                # No point pressed (a touch between the samples): each force where it acts.
                for force, p in zip(fn, local):
                    f[int(np.argmin(((link.surface.points - p) ** 2).sum(axis=1)))] += force
            out.append(link.kernel.stress(f))
        return out

    def load(self, data, link: Union[int, str] = 0) -> Tuple[float, Optional[np.ndarray]]:
        """What presses link `link`'s skin at the last step, as a load cell under it would say:
        the sum of MuJoCo's normal contact forces on it (N; the forces `stress` spreads over the
        skin) and their centre on the skin's surface, force-weighted (the link's frame, metres;
        None with nothing pressing)."""
        pressing = self._pressing(data)[self._index(link)]
        if pressing is None:
            return 0.0, None
        fn, _, surface = pressing
        total = float(fn.sum())
        return total, (fn @ surface) / total

    def frame(self, data, time: Optional[float] = None) -> SimFrame:
        """The skin's frame now (after the `mj_step` that starts a frame: `SkinLoop` knows when);
        `time` in seconds, the step's start by default."""
        stress = self.stress(data)
        readings, slots, missing = self.response.readings(stress)
        if time is None:
            time = float(data.time) - float(self._model.opt.timestep)
        return SimFrame(time=max(time, 0.0), readings=readings, slots=slots, missing=missing, stress=stress)

    def _index(self, link: Union[int, str]) -> int:
        if isinstance(link, str):
            try:
                return self.links.index(link)
            except ValueError:
                raise UnknownNameError(f"no link {link!r} (links: {self.links})") from None
        return int(link)


def _farthest_from_taxels(points: np.ndarray, taxels: np.ndarray) -> float:
    """The largest distance from a surface point to its nearest taxel."""
    far = 0.0
    for start in range(0, len(points), 4096):
        d2 = ((points[start : start + 4096, None, :] - taxels[None]) ** 2).sum(axis=2)
        far = max(far, float(np.sqrt(d2.min(axis=1).max())))
    return far


def _order_of(ids: np.ndarray, wanted: np.ndarray) -> np.ndarray:
    """For each position in `ids`, its index in `wanted` (the same ids in another order)."""
    where = {int(t): k for k, t in enumerate(np.asarray(wanted))}
    return np.array([where[int(t)] for t in np.asarray(ids)], dtype=np.int64)


def check_timestep(timestep, name: str = "timestep") -> float:
    """`timestep` (seconds) checked for a scene with a skin (`MIN_TIMESTEP` to `MAX_TIMESTEP`);
    `name` says where it came from in the error. Returns it as a float."""
    try:
        dt = float(timestep)
    except (TypeError, ValueError):
        raise ArrayError(f"{name} = {timestep!r}: seconds, a number") from None
    if not MIN_TIMESTEP <= dt <= MAX_TIMESTEP:  # NaN fails too
        raise ArrayError(
            f"{name} = {timestep}: seconds from {MIN_TIMESTEP:g} to {MAX_TIMESTEP:g} (MuJoCo's default is "
            f"0.002; above {MAX_TIMESTEP:g} MuJoCo softens the skin's cover, which it keeps at two steps or slower)"
        )
    return dt


# --- how much a skin holds ------------------------------------------------------------------
#
# MuJoCo's contacts are soft: a body pressed onto another sinks into it until the contact's
# force balances the push. At rest, one contact holds a body of mass m at depth r against
#
#     f = m K imp(r)^2 r / (1 - imp(r)),   K = 1 / (dmax^2 timeconst^2 dampratio^2)
#
# (mj_makeImpedance: the reference acceleration -K imp r, the regulariser (1 - imp) / imp times
# 1/m; K = -solref[0] / dmax^2 for a direct solref), with imp(r) the solimp curve and the time
# constant no shorter than two steps. Past the depth a skin allows, the touch MuJoCo images is
# wider than any cover gives, and a little further the tool sinks through the link.


def contact_params(model, g1: int, g2: int) -> Tuple[np.ndarray, np.ndarray]:
    """The solref and solimp of a contact between geoms `g1` and `g2` as MuJoCo sets them: the
    geom of higher priority's, else mixed by solmix (a direct solref: the smaller); the
    override flag's; the time constant no shorter than two steps (unless refsafe is off); solimp
    clamped as MuJoCo clamps it."""
    mujoco = _mujoco()
    p1, p2 = int(model.geom_priority[g1]), int(model.geom_priority[g2])
    ref1, ref2 = np.array(model.geom_solref[g1]), np.array(model.geom_solref[g2])
    imp1, imp2 = np.array(model.geom_solimp[g1]), np.array(model.geom_solimp[g2])
    if p1 != p2:
        ref, imp = (ref1, imp1) if p1 > p2 else (ref2, imp2)
    else:
        m1, m2 = float(model.geom_solmix[g1]), float(model.geom_solmix[g2])
        small = 1e-15
        mix = m1 / (m1 + m2) if m1 >= small and m2 >= small else (0.5 if m1 < small and m2 < small else float(m1 >= small))
        ref = mix * ref1 + (1 - mix) * ref2 if ref1[0] > 0 and ref2[0] > 0 else np.minimum(ref1, ref2)
        imp = mix * imp1 + (1 - mix) * imp2
    opt = model.opt
    if opt.enableflags & int(mujoco.mjtEnableBit.mjENBL_OVERRIDE):
        ref, imp = np.array(opt.o_solref), np.array(opt.o_solimp)
    ref, imp = np.array(ref, dtype=np.float64), np.array(imp, dtype=np.float64)
    if ref[0] > 0 and not opt.disableflags & int(mujoco.mjtDisableBit.mjDSBL_REFSAFE):
        ref[0] = max(ref[0], 2.0 * float(opt.timestep))
    imp[[0, 1, 3]] = np.clip(imp[[0, 1, 3]], 1e-4, 0.9999)
    imp[2] = max(imp[2], 0.0)
    imp[4] = max(imp[4], 1.0)
    return ref, imp


def impedance(solimp: Sequence[float], depth: float) -> float:
    """MuJoCo's impedance (solimp's curve) at `depth` metres into a contact."""
    dmin, dmax, width, mid, power = (float(v) for v in solimp)
    if dmin == dmax or width <= 1e-15:
        return 0.5 * (dmin + dmax)
    x = depth / width
    if x >= 1.0 or x <= 0.0:
        return dmax if x >= 1.0 else dmin
    if power == 1.0:
        y = x
    elif x <= mid:
        y = x**power / mid ** (power - 1.0)
    else:
        y = 1.0 - (1.0 - x) ** power / (1.0 - mid) ** (power - 1.0)
    return dmin + y * (dmax - dmin)


def allowed_depth(model, skin_geom: int, other: int) -> float:
    """How deep geom `other` may press into the link's skin where the link's geom `skin_geom`
    takes the contact: the cover (`HULL_DEPTH`), plus the other geom's own give where MuJoCo
    takes that geom's softness (a higher priority: the kit hand's flesh), its solimp width."""
    give = float(model.geom_solimp[other][2]) if model.geom_priority[other] > model.geom_priority[skin_geom] else 0.0
    return HULL_DEPTH + give


def holding_force(model, mass: float, tool_geom: int, skin_geom: int) -> Tuple[float, float]:
    """The force (N) at which a tool of `mass` kg, pressing with its geom `tool_geom` on a link's
    geom `skin_geom`, sinks as deep as the skin allows (`allowed_depth`), and that depth (m):
    MuJoCo's soft contact at rest (see above), the whole force on one contact. Exact for a ball;
    a tool that touches at several points (a bar, a hand) spreads its force and its mass over
    them, so its own limit lies near this, not on it."""
    ref, imp = contact_params(model, tool_geom, skin_geom)
    depth = allowed_depth(model, skin_geom, tool_geom)
    d = impedance(imp, depth)
    dmax2 = max(imp[1] ** 2, 1e-15)
    stiffness = 1.0 / max(dmax2 * (ref[0] * ref[1]) ** 2, 1e-15) if ref[0] > 0 else -ref[0] / dmax2
    return float(mass * stiffness * d * d * depth / (1.0 - d)), depth


def skin_geoms(model) -> np.ndarray:
    """The geoms that carry a skin: every geom that collides on a body with a skin's sensor
    surface (`attach`'s cover, or the robot's own with contact="model")."""
    names = [model.geom(g).name for g in range(model.ngeom)]
    bodies = {int(model.geom_bodyid[g]) for g, n in enumerate(names) if n.startswith("skin_") and n.endswith("_surface")}
    colliding = (model.geom_contype != 0) | (model.geom_conaffinity != 0)
    return np.array([g for g in range(model.ngeom) if colliding[g] and int(model.geom_bodyid[g]) in bodies], dtype=np.int64)


def collide(model, g1: int, g2: int) -> bool:
    """MuJoCo's contype / conaffinity test: can the two geoms touch at all."""
    return bool(
        (model.geom_contype[g1] & model.geom_conaffinity[g2]) or (model.geom_contype[g2] & model.geom_conaffinity[g1])
    )


def robot_from_urdf(path: _PathLike):
    """A `mujoco.MjSpec` of a URDF (MuJoCo's own importer), with every link kept as a body (no
    fixed links fused away), so that the skin's links find theirs by name."""
    mujoco = _mujoco()
    spec = mujoco.MjSpec.from_file(str(path))
    spec.compiler.fusestatic = False
    return spec
