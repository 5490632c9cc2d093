"""The simulated robot and its skin over ROS 2's middleware: the loop robot -> joint states ->
skin -> events -> controller, with the skin in its own process as on a real robot.

`SkinLoop` runs the session in-process. `ZenohLoop` runs the same scene against a `skin run`
node instead: it writes the skin's CAN traffic into the pipe that node reads (`--log PIPE`, as
the buses would carry it), publishes the robot's `/joint_states` as an rmw_zenoh node does, and
hears the node's events on `/skin/events` over Zenoh, where the controller reads the gate's
action. The two loops give the same events for the same scene.

    # a shell: the skin node, listening for this loop's Zenoh peer
    mkfifo /tmp/skin.can
    skin run arm/run.toml --log /tmp/skin.can -o out --zenoh-listen tcp/127.0.0.1:7447 \\
        --joint-states /joint_states

    # Python: the robot
    from skin.sim.zenoh import RosNode, ZenohLoop, open_pipe
    with RosNode("tcp/127.0.0.1:7447") as node, open_pipe("/tmp/skin.can") as can:
        loop = ZenohLoop(model, data, bridge, node, can, settings=skin.read_session_settings("arm/run.toml"),
                         joints=["shoulder", "elbow"], control=arm)
        events = loop.run(10.0) + loop.finish()

Lock-step: after each frame the loop waits for the node to have processed it (its
`tactile_state`, which the node puts on the network only after the events it gave at that
frame), so the controller acts on exactly the events an in-process session would have given by
then. The complete frames that learn the baseline (the first `[baseline] frames`, and those
after a tare) give no `tactile_state` and are not waited for. The node must stamp on the input's
clock (`skin run`'s default, not `--ros-time rebase`): frames and joint states are matched by
their stamps, to the microsecond.

The names, attachments and CDR of what goes over Zenoh are skin-ros's (the crate `skin run`
publishes with), reached through the native module. Needs `pip install eclipse-zenoh`.
"""

from __future__ import annotations

import errno
import math
import os
import queue
import struct
import threading
import time
from typing import IO, Any, Callable, List, Mapping, Optional, Sequence

from .. import _skin
from .._errors import ArrayError, SessionError
from .bridge import SimFrame, SkinBridge
from .loop import MAX_EVENTS, Control, JointReader, SkinLoop

#: Seconds a frame is waited for before the loop gives up on the node (a node that stopped, a
#: pipe nobody reads).
FRAME_TIMEOUT_S = 10.0

#: Seconds `ZenohLoop.finish` waits for the node to end (it drains its events to the network
#: first: up to `skin run --zenoh-drain`, 30 s by default, on a congested link).
FINISH_TIMEOUT_S = 60.0


def _us(t: float) -> int:
    """Seconds to whole microseconds as `skin` rounds them (half away from zero), exactly."""
    x = t * 1e6
    f = math.floor(x)
    return int(f) + (1 if x - f >= 0.5 else 0)


def open_pipe(path, node=None, timeout: float = FRAME_TIMEOUT_S) -> IO[str]:
    """Opens the named pipe `path` for writing once its reader (the skin node) has opened it:
    SessionError after `timeout` s, or as soon as `node` (its `subprocess.Popen`) has exited,
    instead of waiting for a reader forever."""
    deadline = time.monotonic() + timeout
    while True:
        try:
            fd = os.open(path, os.O_WRONLY | os.O_NONBLOCK)
            break
        except OSError as e:
            if e.errno != errno.ENXIO:
                raise
        if node is not None and node.poll() is not None:
            raise SessionError(f"the skin node exited (status {node.returncode}) before reading {path}: its standard error says why")
        if time.monotonic() > deadline:
            raise SessionError(f"nobody opened {path} for reading within {timeout:g} s: is `skin run --log {path}` running?")
        time.sleep(0.01)
    os.set_blocking(fd, True)
    return os.fdopen(fd, "w")

JOINT_STATE = "sensor_msgs/msg/JointState"
TOUCH_EVENT = "skin_msgs/msg/TouchEvent"
TACTILE_STATE = "skin_msgs/msg/TactileState"


def _zenoh():
    try:
        import zenoh
    except ImportError as e:  # pragma: no cover - said to the user
        raise ImportError("skin.sim.zenoh needs Zenoh's Python package: pip install eclipse-zenoh") from e
    return zenoh


class RosNode:
    """A Zenoh session that speaks as an rmw_zenoh node named `name`: a peer connected to
    `connect` (`tcp/HOST:PORT`, a `skin run --zenoh-listen` endpoint or a Zenoh router), its
    node and entities announced by liveliness tokens, its samples carrying rmw_zenoh's
    attachment. `domain`: the ROS domain id. Close it (or use `with`)."""

    def __init__(self, connect: str, *, name: str = "skin_sim", namespace: str = "/", domain: int = 0) -> None:
        zenoh = _zenoh()
        conf = zenoh.Config()
        conf.insert_json5("mode", '"peer"')
        conf.insert_json5("connect/endpoints", _json_list([connect]))
        conf.insert_json5("listen/endpoints", "[]")
        # The skin node may start after this one: keep trying to reach it (the loop waits for
        # it, with its own timeout, before the first frame).
        conf.insert_json5("connect/timeout_ms", "-1")
        conf.insert_json5("connect/exit_on_failure", "false")
        conf.insert_json5("scouting/multicast/enabled", "false")
        self.name, self.namespace, self.domain = name, namespace, domain
        self.session = zenoh.open(conf)
        self.zid = str(self.session.zid())
        self._ids = 0
        self._tokens: List[Any] = []
        self._closed = False

    def entity(self, kind: str, topic: str, type_name: str, qos: str) -> tuple:
        """Announces the node's next entity (`MP` publisher, `MS` subscription) on `topic`;
        returns its data key expression and GID."""
        self._ids += 1
        key, node_token, token, gid = _skin._rmw_zenoh_entity(
            self.domain, self.zid, self.namespace, self.name, self._ids, kind, topic, type_name, qos
        )
        live = self.session.liveliness()
        if not self._tokens:
            self._tokens.append(live.declare_token(node_token))
        self._tokens.append(live.declare_token(token))
        return key, gid

    def key(self, topic: str, type_name: str) -> str:
        """The data key expression of `topic` (its type's name and hash in it), nothing declared."""
        return _skin._rmw_zenoh_entity(self.domain, self.zid, self.namespace, self.name, 0, "MS", topic, type_name, "frames")[0]

    def joint_states(self, topic: str = "/joint_states") -> "JointStatePublisher":
        return JointStatePublisher(self, topic)

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        for t in reversed(self._tokens):
            t.undeclare()
        self.session.close()

    def __enter__(self) -> "RosNode":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _json_list(items: Sequence[str]) -> str:
    return "[" + ", ".join('"' + i.replace("\\", "\\\\").replace('"', '\\"') + '"' for i in items) + "]"


class JointStatePublisher:
    """`sensor_msgs/msg/JointState` on `topic`, announced as rmw_zenoh announces a driver's
    publisher (reliable, volatile, keep last 10). Its samples are put with Zenoh's blocking
    congestion control, not rmw_zenoh's dropping one for keep-last topics: a simulation in
    lock-step with the skin loses no joint state to a busy link, it waits."""

    def __init__(self, node: RosNode, topic: str = "/joint_states") -> None:
        zenoh = _zenoh()
        #: The topic, as given.
        self.topic = topic
        key, self._gid = node.entity("MP", topic, JOINT_STATE, "frames")
        self._publisher = node.session.declare_publisher(key, congestion_control=zenoh.CongestionControl.BLOCK)
        self._seq = 0
        #: Messages published.
        self.published = 0

    def publish(self, time: float, names: Sequence[str], positions, velocities=()) -> None:
        """One message stamped `time` (s, the skin's clock): positions (rad or m) and velocities
        (none, or one per joint) of the joints `names`."""
        cdr = _skin._ros_joint_state(time, list(names), [float(p) for p in positions], [float(v) for v in velocities])
        self._seq += 1
        self._publisher.put(cdr, attachment=_skin._rmw_zenoh_attachment(self._seq, self._gid))
        self.published += 1

    @property
    def matched(self) -> bool:
        """A subscription (the skin node's) hears this topic now."""
        return bool(self._publisher.matching_status.matching)

    def close(self) -> None:
        self._publisher.undeclare()


class SkinListener:
    """A skin node's events (`PREFIX/events`) and the frames it finished (`PREFIX/*/tactile_state`
    of every link), heard in the order the node put them out (one subscription over both)."""

    def __init__(self, node: RosNode, links: int, *, prefix: str = "/skin") -> None:
        prefix = "/" + prefix.strip("/")
        self._prefix = prefix
        #: The node's events topic.
        self.events_topic = prefix + "/events"
        self._events_key, _ = node.entity("MS", prefix + "/events", TOUCH_EVENT, "events")
        # Every link's tactile_state key ends alike: the topic's last token, its type and hash.
        self._state_tail = "/tactile_state/" + node.key("/x/tactile_state", TACTILE_STATE).split("/x/tactile_state/", 1)[1]
        self._links = links
        self._samples: "queue.SimpleQueue" = queue.SimpleQueue()
        # One subscription over the node's topics (its images and clouds too): Zenoh hands one
        # subscription's samples over in the order they came, which two would not promise.
        self._subscriber = node.session.declare_subscriber(
            f"{node.domain}/{prefix.strip('/')}/**", lambda s: self._samples.put((str(s.key_expr), bytes(s.payload.to_bytes())))
        )
        #: Per frame stamp (µs), how many links' tactile_state came.
        self._states: dict = {}
        # The node's events publisher, as its liveliness token shows it: there, then gone when
        # its run ends (its events all sent before: the node drains them first). Only the first
        # node seen counts, and it is back if it reconnects.
        events_topic = "%" + prefix.strip("/").replace("/", "%") + "%events"
        self._lock = threading.Lock()
        self._node: Optional[str] = None
        self._gone = threading.Event()
        self._alive = threading.Event()
        self._tokens = node.session.liveliness().declare_subscriber(
            f"@ros2_lv/{node.domain}/*/0/*/MP/%/*/*/{events_topic}/**", self._token, history=True
        )

    def wait(self, stamp_us: int, timeout: float, stop: Callable[[Any], bool]) -> List:
        """The events heard until every link's tactile_state stamped `stamp_us` (µs) came, or an
        event for which `stop(event)` is true; raises SessionError when that takes longer than
        `timeout` s."""
        got: List = []
        deadline = time.monotonic() + timeout
        while self._states.get(stamp_us, 0) < self._links:
            try:
                k, payload = self._samples.get(timeout=max(0.0, deadline - time.monotonic()))
            except queue.Empty:
                raise SessionError(
                    f"no word from the skin node on its frame t = {stamp_us * 1e-6:.6f} s within {timeout:g} s: "
                    "is `skin run` still running (its standard error says why not), reading the pipe, on the "
                    f"input's clock (not --ros-time rebase), under the prefix {self._prefix}? Were the loop's "
                    "settings read from its run.toml? (A tactile_state dropped on a congested link stops it too.)"
                ) from None
            event = self._take(k, payload)
            if event is not None:
                got.append(event)
                if stop(event):
                    break
        self._states.pop(stamp_us, None)
        return got

    def _token(self, sample) -> None:
        node = str(sample.key_expr).split("/")[2]
        with self._lock:
            if self._node is None:
                self._node = node
            if node != self._node:
                return
            if sample.kind == _zenoh().SampleKind.DELETE:
                self._gone.set()
            else:
                self._gone.clear()
                self._alive.set()

    @property
    def alive(self) -> bool:
        """The node's events publisher is on the network."""
        return self._alive.is_set() and not self._gone.is_set()

    def until_gone(self, timeout: float) -> bool:
        """Waits up to `timeout` s for the node's events publisher to leave; whether it did."""
        return self._gone.wait(timeout)

    def drain(self) -> List:
        """The events heard so far, without waiting."""
        got: List = []
        while True:
            try:
                k, payload = self._samples.get_nowait()
            except queue.Empty:
                return got
            event = self._take(k, payload)
            if event is not None:
                got.append(event)

    def _take(self, key: str, payload: bytes):
        if key == self._events_key:
            return _skin._ros_event(payload)
        if key.endswith(self._state_tail) and len(payload) >= 12:
            # The CDR header (4 bytes), then the stamp: sec (int32), nanosec (uint32).
            sec, nsec = struct.unpack_from("<iI", payload, 4)
            stamp = sec * 1_000_000 + nsec // 1000
            self._states[stamp] = self._states.get(stamp, 0) + 1
        return None

    def close(self) -> None:
        self._tokens.undeclare()
        self._subscriber.undeclare()


class ZenohLoop(SkinLoop):
    """A MuJoCo model stepped with a `skin run` node over Zenoh (see the module's docs): a
    `SkinLoop` whose session is in another process, everything else its own (the frames' clock,
    sensors computed only at frames, presses deeper than a skin gives watched, `events`,
    `new_events`, `run`). `can`: the text stream the node reads as its `--log` (a named pipe,
    `open_pipe`); `node`: this loop's `RosNode`, connected to the skin node; `settings`: the
    node's session settings (`skin.read_session_settings(its run.toml)`), for the complete
    frames that learn its baseline; `joints`: the robot's joints whose positions go out on
    `joint_states` (the names its URDF gives them, MuJoCo's joints of those names), at every
    skin frame and every `joint_period` s between. A controller `control` is called before
    every step with this loop: `loop.gate` is the last gate action heard."""

    def __init__(
        self,
        model,
        data,
        bridge: SkinBridge,
        node: RosNode,
        can: IO[str],
        *,
        settings: Mapping[str, Any],
        joints: Sequence[str],
        control: Optional[Control] = None,
        prefix: str = "/skin",
        joint_states: str = "/joint_states",
        joint_period: float = 0.01,
        timeout: float = FRAME_TIMEOUT_S,
        max_events: Optional[int] = MAX_EVENTS,
    ) -> None:
        if bridge.busmap is None:
            raise ArrayError("the bridge has no bus map: a skin node reads CAN traffic (give the config's busmap)")
        self._gate: Optional[str] = None
        super().__init__(model, data, bridge, None, control=control, max_events=max_events, joints=joints, joint_period=joint_period)
        self._baseline = int(settings["baseline"]["frames"])
        self._can = can
        self._publisher = node.joint_states(joint_states)
        self._listener = SkinListener(node, len(bridge.links), prefix=prefix)
        self._timeout = timeout
        self._cycle = 0
        # The time the node stamps the next frame with: that of its syncs, written a frame ahead.
        self._next_time: Optional[float] = None
        # Complete frames still learning a baseline (the node puts out no tactile_state for them).
        self._learning = self._baseline
        self._wait_for_node()

    def _wait_for_node(self) -> None:
        """Until the skin node hears this loop's joint states and publishes its events (what
        either sends before that would be lost, and the node would report joint states missing)."""
        since = time.monotonic()
        while not (self._publisher.matched and self._listener.alive):
            if time.monotonic() - since > self._timeout:
                missing = []
                if not self._publisher.matched:
                    missing.append(f"a subscription to {self._publisher.topic} (skin run --joint-states {self._publisher.topic})")
                if not self._listener.alive:
                    missing.append(f"a publisher of {self._listener.events_topic} (the run's --ros-prefix and domain)")
                raise SessionError(
                    f"no skin node within {self._timeout:g} s: not seen {' nor '.join(missing)}. Is `skin run` "
                    "running (its standard error says why not) and listening where this node connects "
                    "(--zenoh-listen), in the same ROS domain?"
                )
            time.sleep(0.01)

    @property
    def joint_states_published(self) -> int:
        """The joint-state messages this loop published."""
        return self._publisher.published

    # SkinLoop's session hooks, over Zenoh.

    def _check_session(self) -> None:
        pass  # the node checks its input against its own layout

    @property
    def gate(self) -> Optional[str]:
        """The gate's action last heard (None before any)."""
        return self._gate

    def _record(self, events: List) -> None:
        for e in events:
            if e.kind == "gate":
                self._gate = e.action
        super()._record(events)

    def _stamp(self, before: float) -> float:
        """The stamp of a frame starting at `before` (s): the time its syncs were written at,
        to the microsecond as the node reads it."""
        return self._next_time if self._next_time is not None else before

    def _send_joints(self, joints: JointReader, before: float, frame_step: bool) -> None:
        # A frame's joint state is stamped with the frame's own time.
        q, v = joints.read(self.data)
        self._publisher.publish(self._stamp(before) if frame_step else before, joints.names, q, v)

    def _between(self) -> List:
        return self._listener.drain()

    def _deliver(self, frame: SimFrame, before: float) -> List:
        """The frame into the pipe, then (past the baseline) the node's answer to it."""
        stamp = self._stamp(before)
        heard = self._listener.drain()
        busmap = self.bridge.busmap
        period = self.bridge.steps_per_frame * self.model.opt.timestep
        text = busmap.candump(frame.slots, stamp, self._cycle, frame.missing, sync=self._cycle == 0)
        # The next cycle's syncs complete this one: the node takes the frame now.
        self._next_time = stamp + period
        text += busmap.candump_sync(self._next_time, self._cycle + 1)
        self._cycle += 1
        self._can.write(text)
        self._can.flush()
        if self._learning > 0:
            self._learning -= int(not frame.missing)
            return heard
        tare = lambda e: e.kind == "tare"
        got = self._listener.wait(_us(stamp), self._timeout, tare)
        told = [e for e in got if tare(e)]
        if told:
            # The tare frame and the next ones learn the baseline again: no tactile_state.
            self._learning = int(told[-1]["frames"]) - int(not frame.missing)
        return heard + got

    def finish(self, wait: float = FINISH_TIMEOUT_S) -> List:
        """Ends the skin's input: the pipe closes, the node releases its open touches and ends
        its run. Returns the events it sent until its events publisher left the network (its
        liveliness token gone: the run is over, its events drained first); SessionError if that
        takes longer than `wait` s (the events heard are kept in `events` all the same)."""
        self._can.close()
        ended = self._listener.until_gone(wait)
        got = self._listener.drain()
        self._record(got)
        if not ended:
            raise SessionError(
                f"the skin node did not end within {wait:g} s of its input's end: its last events may be missing "
                "(a long --zenoh-drain? its standard error says more)"
            )
        return got

    def close(self) -> None:
        self._listener.close()
        self._publisher.close()
