"""skin.sim: the skin as a MuJoCo sensor, its frames through the session (headless).

MuJoCo (`pip install mujoco`, Python 3.11+) is in the test requirements; without it these tests
skip, saying so, unless SKIN_REQUIRE_MUJOCO is set (CI sets it)."""

import json
import os
import warnings

import numpy as np
import pytest

import skin
from conftest import FIXTURES, SHARED_DATA

try:
    import mujoco
except ImportError:  # pragma: no cover - depends on the machine
    if os.environ.get("SKIN_REQUIRE_MUJOCO"):
        raise
    pytest.skip("MuJoCo is not installed (pip install mujoco; Python 3.11 or later)", allow_module_level=True)

from skin.sim import FINGERS, Kit, PathFollower, SkinBridge, SkinLoop, bare_robot, robot_from_urdf, touches, two_joint_arm
from skin.sim.bridge import HULL_DEPTH, MAX_TIMESTEP, allowed_depth, holding_force
from skin.sim.loop import MAX_EVENTS

CONFIG = FIXTURES / "session" / "run.toml"


def scene(config=CONFIG, tools=("sphere",), sphere_radius=0.02, bridge=None, spec=None, **attach):
    """The fixture forearm (or `bridge`'s skin) on fixed bodies, the kit's tools, compiled."""
    bridge = bridge or SkinBridge.from_config(config)
    spec = spec or bare_robot(bridge.layout)
    kit = Kit(spec)
    for tool in tools:
        {"sphere": lambda: kit.add_sphere(radius=sphere_radius), "bar": lambda: kit.add_bar(radius=0.015), "hand": kit.add_hand}[tool]()
    bridge.attach(spec, **attach)
    model = spec.compile()
    data = mujoco.MjData(model)
    kit.bind(model, data)
    return bridge, kit, model, data


def contact_on_surface(model, data, body):
    """MuJoCo's contact with `body`, moved from halfway into the penetration to the skin's
    surface, and its normal force; None without one."""
    f = np.zeros(6)
    for i in range(data.ncon):
        c = data.contact[i]
        sides = (model.geom_bodyid[c.geom1], model.geom_bodyid[c.geom2])
        if body not in sides or sides[0] == sides[1]:
            continue
        outward = c.frame[:3] if sides[0] == body else -c.frame[:3]
        mujoco.mj_contactForce(model, data, i, f)
        return c.pos + outward * abs(c.dist) / 2, f[0]
    return None


def on_frames(loop, fn):
    """`until` for loop.run: fn(loop) after every step that made a skin frame."""

    def until(l):
        if l.framed:
            fn(l)
        return False

    return until


# --- MuJoCo's sensor against an independent reference ---------------------------------------


@pytest.mark.parametrize("other_sensor, steps_before", [(False, 0), (True, 0), (False, 7)])
def test_the_sensor_reads_the_analytic_depth_of_a_sphere_at_every_frame(other_sensor, steps_before):
    # A sphere's depth at a point is R - |p - c|: MuJoCo's tactile sensor, read once per skin
    # frame, must give exactly that for every surface point at the frame's step, over a run long
    # enough that the clock's rounding would show a stale frame. With the skin's sensors alone
    # MuJoCo computes sensors at frame steps only; with another sensor in the model, at every
    # step, the skin's by their interval; a loop started off the frames' grid (steps made
    # before it) keeps to the simulation's clock.
    bridge = SkinBridge.from_config(CONFIG)
    spec = bare_robot(bridge.layout)
    if other_sensor:
        spec.add_sensor(name="ball_height", type=mujoco.mjtSensor.mjSENS_FRAMEPOS, objtype=mujoco.mjtObj.mjOBJ_BODY, objname="forearm")
    bridge, kit, model, data = scene(sphere_radius=0.03, bridge=bridge, spec=spec)
    path = [[0.08 * np.sin(a), 0.12 + 0.15 * k / 8, 0.08 * np.cos(a)] for k, a in enumerate(np.linspace(-0.4, 0.4, 9))]
    normals = np.array(path) * [1, 0, 1]
    kit.slide("sphere", path, normals, 8.0, start=1.0, duration=4.0, roll=True)
    for _ in range(steps_before):
        mujoco.mj_step(model, data)
    loop = SkinLoop(model, data, bridge, skin.Session.from_config(CONFIG), control=kit.control)
    assert bridge.owns_all_sensors(model) != other_sensor
    surface = bridge.surface(0)
    ball = model.body("sphere").id
    checked = []

    def check(l):
        depth = bridge.depth(data, "forearm")
        exact = np.maximum(0.0, 0.03 - np.linalg.norm(surface.points - data.xpos[ball], axis=1))
        checked.append((np.abs(depth - exact).max(), exact.max()))

    loop.run(5.2 - steps_before * model.opt.timestep, until=on_frames(loop, check))
    pressed = [err for err, deepest in checked if deepest > 0]
    assert len(checked) == 104 - (steps_before > 0) and len(pressed) > 70
    # Equal to the precision of the mesh (single-precision vertices); a stale frame is off by
    # tenths of a millimetre.
    assert max(err for err, _ in checked) < 1e-6


# --- a sphere pressed at a known point, rolled along the forearm ----------------------------


def inside_a_module(layout):
    """The taxel of the fixture forearm nearest its top among those with the most neighbours
    within 12.5 mm (inside a module, away from the strips between modules)."""
    p = layout[0].positions
    d = np.linalg.norm(p[:, None] - p[None], axis=2)
    near = ((d > 1e-4) & (d < 0.0125)).sum(axis=1)
    full = np.flatnonzero(near == near.max())
    return int(full[np.argmin(np.abs(p[full, 0]) + np.abs(p[full, 1] - 0.18))])


def test_a_sphere_pressed_at_a_known_point():
    bridge, kit, model, data = scene()
    link = bridge.layout[0]
    i = inside_a_module(bridge.layout)
    point, normal = link.positions[i], link.normals[i]
    forces = [3.0, 6.0, 12.0, 20.0]
    for k, f in enumerate(forces):
        kit.press("sphere", point, normal, f, start=1.5 + 1.5 * k, duration=1.2)
    loop = SkinLoop(model, data, bridge, skin.Session.from_config(CONFIG), control=kit.control)
    forearm = model.body("forearm").id
    seen = []

    def sample(l):
        for k in range(len(forces)):
            if abs(l.frame.time - (1.5 + 1.5 * k + 0.8)) < 1e-3:
                at, fn = contact_on_surface(model, data, forearm)
                contacts = l.session.contacts(0)
                summed = sum(c.mean_pressure * len(c.taxels) for c in contacts)
                seen.append((contacts, at, fn, summed))

    events = loop.run(1.5 + 1.5 * len(forces), until=on_frames(loop, sample)) + loop.finish()
    assert len(seen) == len(forces)
    for (contacts, at, fn, _), f in zip(seen, forces):
        assert len(contacts) == 1, f"{f} N: {len(contacts)} contacts"
        err = np.linalg.norm(np.array(contacts[0].centroid) - at)
        assert err < 0.003, f"{f} N: centroid {1e3 * err:.2f} mm from MuJoCo's contact point"
        assert abs(fn - f) < 0.1 * f, f"MuJoCo's contact force {fn:.2f} N for {f} N pressed"
    summed = [s for *_, s in seen]
    assert all(b > a for a, b in zip(summed, summed[1:])), summed
    touches = [e for e in events if e.kind == "released"]
    assert len(touches) == len(forces) and all(e["class"] == "non_hand" for e in touches)


def test_a_sphere_rolled_along_the_forearm_follows_mujocos_contact_path():
    bridge, kit, model, data = scene(sphere_radius=0.03)
    angles = np.linspace(-0.4, 0.5, 10)
    path = np.array([[0.08 * np.sin(a), 0.12 + 0.1 * k / 9, 0.08 * np.cos(a)] for k, a in enumerate(angles)])
    kit.slide("sphere", path, path * [1, 0, 1], 8.0, start=1.5, duration=3.0, roll=True)
    loop = SkinLoop(model, data, bridge, skin.Session.from_config(CONFIG), control=kit.control)
    forearm = model.body("forearm").id
    ours, theirs = [], []

    def sample(l):
        if 1.8 < l.time < 4.3:
            contacts = l.session.contacts(0)
            found = contact_on_surface(model, data, forearm)
            if contacts and found:
                ours.append(np.array(contacts[0].centroid))
                theirs.append(found[0])

    events = loop.run(5.0, until=on_frames(loop, sample)) + loop.finish()
    assert [e.kind for e in events if e.kind in ("appeared", "released")] == ["appeared", "released"]
    assert len(ours) >= 45
    theirs = np.array(theirs)

    def to_path(p):
        a, b = theirs[:-1], theirs[1:]
        t = np.clip(((p - a) * (b - a)).sum(1) / np.maximum(((b - a) ** 2).sum(1), 1e-18), 0, 1)
        return np.linalg.norm(p - (a + t[:, None] * (b - a)), axis=1).min()

    off = np.array([to_path(p) for p in ours])
    # The path crosses the strips between the forearm's modules, where no taxel lies for 8 mm
    # and more: there the taxels' centroid is drawn to the module that has them (up to 4 mm
    # here); everywhere else it lies within 3 mm.
    assert np.percentile(off, 90) < 0.003 and off.max() < 0.005, (np.percentile(off, 90), off.max())
    assert np.median(off) < 0.0015


# --- the scene kit and HandsNet ------------------------------------------------------------


def central_taxels(config=CONFIG):
    tmap = skin.read_map(FIXTURES / "forearm" / "layout.json")
    lo, hi = tmap.uv.min(0), tmap.uv.max(0)
    c, half = (lo + hi) / 2, (hi - lo) / 2
    return (np.abs(tmap.uv[:, 0] - c[0]) <= 0.6 * half[0]) & (np.abs(tmap.uv[:, 1] - c[1]) <= 0.3 * half[1])


@pytest.fixture(scope="module")
def fifty_presses():
    """50 scripted presses of the fixture forearm (hand, bar, sphere in turn; random places,
    forces, yaws and fingers), through the session with the shipped models."""
    bridge, kit, model, data = scene(tools=("hand", "bar", "sphere"), sphere_radius=0.03)
    link = bridge.layout[0]
    central = central_taxels()
    actions = kit.random_presses(link.positions[central], link.normals[central], 50, seed=11, yaws=(-0.6, 0.6))
    loop = SkinLoop(model, data, bridge, skin.Session.from_config(CONFIG), control=kit.control)
    forearm = model.body("forearm").id
    pads = [set() for _ in actions]

    def sample(l):
        for k, a in enumerate(actions):
            if a.tool == "hand" and a.start + 0.3 < l.time < a.start + 0.8:
                forces = kit.touching("hand", forearm, distal=True)
                pads[k] |= {p for p, f in forces.items() if p in FINGERS and f > 0.3}

    end = actions[-1].start + actions[-1].duration + 0.5
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", skin.SkinWarning)  # (their records are checked)
        events = loop.run(end, until=on_frames(loop, sample)) + loop.finish()
    return actions, pads, events, loop.overpresses


def touches_of(actions, events):
    """Per action, the touches that appeared while it lasted."""
    all_touches = touches(events)
    return [[t for t in all_touches if a.start <= t["start"] <= a.start + a.duration] for a in actions]


def test_fifty_presses_handsnet_unchanged_tells_hands_from_objects(fifty_presses):
    actions, _, events, overpresses = fifty_presses
    # Forces of 3 to 20 N stay within the cover, but for a moment: a bar landing along the
    # forearm's straight top line rests on two contacts that MuJoCo moves along the line, and
    # dips past the cover (9 mm at 17 N) for a tenth of a second before it settles at 4 mm.
    # Reported all the same.
    for o in overpresses:
        landing = [a for a in actions if a.tool == "bar" and a.start <= o.start <= a.start + 0.3]
        assert o.geom == "bar_rod" and landing and not o.through, o
        assert o.depth < 2 * o.allowed and o.end - o.start < 0.3, o
    assert len(overpresses) <= 3, overpresses
    per_press = touches_of(actions, events)
    right = {"hand": [], "non_hand": []}
    for a, touches in zip(actions, per_press):
        want = "hand" if a.tool == "hand" else "non_hand"
        right[want].append(len(touches) >= 1 and touches[0]["class"] == want)
    hands, others = np.mean(right["hand"]), np.mean(right["non_hand"])
    assert len(right["hand"]) == 17 and len(right["non_hand"]) == 33
    assert hands >= 0.9 and others >= 0.9, (hands, others)


def test_the_hand_presses_with_the_fingers_the_script_names(fifty_presses):
    # A lifted finger never presses; a pressing one reaches the skin unless the skin ends under
    # it (a thumb over the forearm's flank).
    actions, pads, _, _ = fifty_presses
    hands = [(set(a.fingers), p) for a, p in zip(actions, pads) if a.tool == "hand"]
    assert all(p <= chosen for chosen, p in hands), hands
    assert np.mean([p == chosen for chosen, p in hands]) >= 0.75, hands
    assert np.mean([p == chosen - {"thumb"} for chosen, p in hands if p != chosen]) == 1.0, hands


def test_a_hand_grasps_the_forearm_with_every_finger():
    bridge, kit, model, data = scene(tools=("hand",))
    kit.grasp("hand", [0, 0.18, 0.08], [0, 0, 1], 15.0, start=1.5, duration=1.5, axis=[0, 1, 0])
    loop = SkinLoop(model, data, bridge, skin.Session.from_config(CONFIG), control=kit.control)
    forearm = model.body("forearm").id
    grip = {}

    def sample(l):
        if abs(l.frame.time - 2.5) < 1e-3:
            grip.update(kit.touching("hand", forearm, distal=True))
            grip["curl"] = min(data.qpos[model.joint(f"hand_{f}_1").qposadr[0]] for f in FINGERS[1:])

    events = loop.run(3.5, until=on_frames(loop, sample)) + loop.finish()
    assert loop.overpresses == []  # the flesh gives, within what a hand and a skin give
    # The fingers wrap around the forearm (the map's other direction): each presses with its
    # pad, flexed by half a radian and more.
    assert all(grip[f] > 0.5 for f in FINGERS) and grip["curl"] > 0.5, grip
    found = touches(events)
    assert len(found) == 1 and found[0]["class"] == "hand"
    with pytest.raises(ValueError, match="axis lies along the normal"):
        kit.grasp("hand", [0, 0.18, 0.08], [0, 0, 1], 15.0, start=9.0, duration=1.0, axis=[0, 0, 2])


def test_every_hand_touch_gets_its_parts(fifty_presses):
    # The segmenter runs on the touches HandsNet calls hands and names parts it knows. (How
    # often its parts are the fingers that pressed is the segmenter's accuracy, not the
    # bridge's: see python/bench/sim_presses.py.)
    actions, _, events, _ = fifty_presses
    hands = [t[0] for a, t in zip(actions, touches_of(actions, events)) if a.tool == "hand" and t and t[0]["class"] == "hand"]
    assert hands and all(t["parts"] for t in hands)
    names = {p["part"] for t in hands for p in t["parts"]}
    assert names <= set(FINGERS) | {"palm"} and "palm" in names


# --- skin in the loop: the pHRI scene -------------------------------------------------------


def test_the_gate_stops_the_arm_when_a_hand_touches_it():
    # The fixture session's gate: hand -> comply (the arm stops following its path and yields),
    # non_hand -> stop. A hand on the moving forearm halts the path within a decision; the
    # path goes on when the hand leaves; a bar halts it as well; untouched it never stops.
    bridge = SkinBridge.from_config(CONFIG)
    spec = two_joint_arm("forearm")
    bridge, kit, model, data = scene(tools=("hand", "bar"), bridge=bridge, spec=spec)
    path = lambda s: np.array([0.5 * np.sin(2 * np.pi * s / 8), 0.4 * np.sin(2 * np.pi * s / 6)])
    arm = PathFollower(model, data, ["shoulder", "elbow"], path)
    kit.press("hand", [0, 0.18, 0.08], [0, 0, 1], 12.0, start=2.0, duration=2.0, body="forearm")
    kit.press("bar", [0, 0.2, 0.08], [0, 0, 1], 12.0, start=6.0, duration=2.0, body="forearm")

    def control(loop):
        kit.control(loop)
        arm(loop)
        trace.append((loop.time, loop.gate, arm.s, arm.q()))

    trace = []
    loop = SkinLoop(model, data, bridge, skin.Session.from_config(CONFIG), control=control)
    events = loop.run(10.0) + loop.finish()
    decided = [e for e in events if e.kind == "released"]
    assert [e["class"] for e in decided] == ["hand", "non_hand"]
    touched = [e.time for e in events if e.kind == "appeared"]
    gate = {round(e.time, 3): e.action for e in events if e.kind == "gate"}
    assert list(gate.values()) == ["comply", "resume", "stop", "resume"]
    t, gates, s, q = zip(*trace)
    t, s, q = np.array(t), np.array(s), np.array(q)
    # Stopped on its path: complying, it gives way to the hand's push (a few hundredths of a
    # radian); stopped, it holds (its servos give a hundredth of a radian as the bar presses).
    for start, action, most in ((touched[0], "comply", 0.05), (touched[1], "stop", 0.02)):
        # Stopped from the decision (3 frames after the touch appears) to the release.
        halted = (t > start + 0.2) & (t < start + 1.6)
        assert all(g == action for g, h in zip(gates, halted) if h)
        assert np.ptp(s[halted]) == 0.0
        drift = np.abs(q[halted] - q[halted][0]).max()
        assert drift < most, f"{action}: the arm moved {drift:.3f} rad while halted"
    moving = (t < touched[0]) | ((t > decided[0].time + 0.1) & (t < touched[1])) | (t > decided[1].time + 0.1)
    assert np.all(np.diff(s[moving]) >= 0) and s[-1] > 5.0
    assert np.abs(np.diff(q[t < touched[0]], axis=0)).max() / model.opt.timestep > 0.2


# --- the response model: readings as the real skin gives them -------------------------------


def sim_config(tmp_path, sim: str, busmap=True):
    text = f'layout = "{FIXTURES / "forearm" / "layout.json"}"\n'
    if busmap:
        text += f'busmap = "{FIXTURES / "forearm" / "busmap.toml"}"\n'
    path = tmp_path / "run.toml"
    path.write_text(text + "[sim]\n" + sim)
    return path


def test_untouched_frames_are_rest_gain_and_noise_as_configured(tmp_path):
    config = sim_config(tmp_path, "rest = 300\nrest_spread = 10\nnoise = 2\nseed = 4\n")
    bridge, kit, model, data = scene(config)
    frames = []
    loop = SkinLoop(model, data, bridge, skin.Session.from_config(config))
    loop.run(2.0, until=on_frames(loop, lambda l: frames.append(l.frame.readings[0])))
    frames = np.array(frames)
    assert frames.shape == (40, 715) and np.all(frames == np.round(frames))
    per_taxel = frames.mean(axis=0)
    # Rests within 300 +- 10, each seen through 40 frames of noise (2 counts: 0.3 on a mean).
    assert 289 <= per_taxel.min() and per_taxel.max() <= 311 and abs(per_taxel.mean() - 300) < 1
    assert abs(frames.std(axis=0).mean() - 2.0) < 0.15
    # The same seed, the same frames; another seed, others.
    bridge2, _, model2, data2 = scene(config)
    again = []
    loop2 = SkinLoop(model2, data2, bridge2, skin.Session.from_config(config))
    loop2.run(2.0, until=on_frames(loop2, lambda l: again.append(l.frame.readings[0])))
    assert np.array_equal(frames, np.array(again))
    other = SkinBridge.from_config(sim_config(tmp_path, "rest = 300\nrest_spread = 10\nnoise = 2\nseed = 5\n"))
    assert not np.array_equal(other.response.counts([np.zeros(715)])[0], frames[0])


def test_saturation_gain_spread_and_dead_taxels(tmp_path):
    config = sim_config(tmp_path, "full_scale = 1000\nhalf_scale_kpa = 20\nnoise = 0\nrest_spread = 0\ngain_spread = 0.2\ndead = [16, 17]\n")
    bridge = SkinBridge.from_config(config)
    response = bridge.response
    stress = [np.full(715, 1e7)]  # far beyond saturation
    counts = response.counts(stress)[0]
    assert counts.max() == 1000 and counts[2:].min() >= 200 + 0.8 * 1000 * 1e7 / (1e7 + 2e4) - 1
    assert list(counts[:2]) == [200, 200]  # taxels 16 and 17: dead, their rest
    half = response.counts([np.full(715, 2e4)])[0][2:] - 200
    gains = half / 500.0
    assert 0.8 <= gains.min() < 0.85 and 1.15 < gains.max() <= 1.2


def test_missing_modules_and_dropouts_reach_the_session_as_a_logs_do(tmp_path):
    # Module 5 stops delivering once the baseline is learned (20 frames); every module is lost
    # now and then. Each is reported as a CAN log's, and a press is still felt.
    config = sim_config(tmp_path, 'missing_modules = ["can0:5"]\ndropout = 0.002\nseed = 3\n')
    bridge, kit, model, data = scene(config)
    kit.press("sphere", [0, 0.18, 0.08], [0, 0, 1], 8.0, start=2.0, duration=1.0)
    loop = SkinLoop(model, data, bridge, skin.Session.from_config(config), control=kit.control)
    events = loop.run(4.0) + loop.finish()
    incomplete = [e for e in events if e.kind == "incomplete"]
    with_5 = [e for e in incomplete if {"bus": "can0", "address": 5} in e.missing]
    # From the first frame after the 20 complete ones on, every frame lacks module 5.
    first = min(e.time for e in with_5)
    assert first >= 1.0 and len(with_5) == 80 - round(first / 0.05) and len(with_5) >= 45
    others = sum(len(e.missing) for e in incomplete) - len(with_5)
    assert 1 <= others <= 25  # 80 frames x 65 modules x 0.2%: about 10
    assert loop.session.stats["incomplete"] == len(incomplete)
    found = touches(events)  # (this configuration names no model: tracked, not classified)
    assert len(found) == 1 and 2.0 < found[0]["start"] < 2.3


def test_a_layout_with_no_bus_map_pushes_readings_per_taxel(tmp_path):
    config = sim_config(tmp_path, "noise = 0\n", busmap=False)
    bridge, kit, model, data = scene(config)
    kit.press("sphere", [0, 0.18, 0.08], [0, 0, 1], 8.0, start=1.5, duration=1.0)
    loop = SkinLoop(model, data, bridge, skin.Session.from_config(config), control=kit.control)
    events = loop.run(3.0)
    assert loop.frame.slots is None
    assert [e.kind for e in events if e.kind in ("appeared", "released")] == ["appeared", "released"]
    with pytest.raises(ValueError, match="need a bus map"):
        SkinBridge.from_config(sim_config(tmp_path, "dropout = 0.1\n", busmap=False))


# --- bad input: named -----------------------------------------------------------------------


def test_bad_input_is_named(tmp_path):
    bridge = SkinBridge.from_config(CONFIG)
    spec = mujoco.MjSpec()
    spec.worldbody.add_body(name="upper_arm")
    with pytest.raises(ValueError, match="link 'forearm': the model has no body 'forearm' .*upper_arm"):
        bridge.attach(spec)
    with pytest.raises(ValueError, match="bodies names no link"):
        bridge.attach(spec, bodies={"wrist": "upper_arm"})
    with pytest.raises(ValueError, match="contact = 'soft'"):
        bridge.attach(spec, bodies={"forearm": "upper_arm"}, contact="soft")
    spec = bare_robot(bridge.layout, timestep=0.003)
    with pytest.raises(ValueError, match="frame_rate_hz = 20.0: a skin frame must last a whole number"):
        bridge.attach(spec)
    with pytest.raises(ValueError, match=r"\[sim\] dead: taxel 5 is on no link"):
        SkinBridge.from_config(sim_config(tmp_path, "dead = [5]\n"))
    with pytest.raises(ValueError, match=r"\[sim\] missing_modules: can1:5 is no module"):
        SkinBridge.from_config(sim_config(tmp_path, 'missing_modules = ["can1:5"]\n'))
    with pytest.raises(skin.ConfigError, match=r"\[sim\] noise"):
        SkinBridge.from_config(sim_config(tmp_path, "noise = -1\n"))
    with pytest.raises(ValueError, match="spacing_mm"):
        SkinBridge(FIXTURES / "forearm" / "layout.json", spacing_mm=0)
    with pytest.raises(KeyError, match="no tool 'ball'"):
        Kit(bare_robot(bridge.layout)).press("ball", [0, 0, 0], [0, 0, 1], 1.0, 0.0, 1.0)
    with pytest.raises(skin.ConfigError, match=r"\[sim\] key = noize: expected one of frame_rate_hz"):
        SkinBridge(FIXTURES / "forearm" / "layout.json", response={"noize": 1})
    with pytest.raises(skin.ConfigError, match=r"\[sim\] cover_mm = 0"):
        SkinBridge(FIXTURES / "forearm" / "layout.json", response={"cover_mm": 0})
    patch = json.loads((FIXTURES / "hex_patch" / "layout.json").read_text())
    for taxel in patch["links"][0]["taxels"]:
        taxel["id"] += 1_000_000
    (tmp_path / "patch.json").write_text(json.dumps(patch))
    with pytest.raises(ValueError, match="the bus map carries none of link 0's 61 taxels"):
        SkinBridge(tmp_path / "patch.json", busmap=FIXTURES / "forearm" / "busmap.toml")
    spec = bare_robot(bridge.layout)
    with pytest.raises(ValueError, match='body .forearm. has no geom that collides'):
        bridge.attach(spec, contact="model")


@pytest.mark.parametrize(
    "overrides, message",
    [
        ({"noise": "x"}, r"\[sim\]: \[sim\] noise = \"x\": expected counts from 0 to full_scale"),
        ({"noise": None}, r"\[sim\] noise = None: expected counts from 0 to full_scale"),
        ({"noise": float("nan")}, r"\[sim\] noise = NaN: expected counts from 0 to full_scale"),
        ({"frame_rate_hz": "20"}, r"\[sim\] frame_rate_hz = \"20\": expected frames a second from 0.1 to 10000"),
        ({"dead": 5}, r"\[sim\] dead = 5: expected a list of taxel ids"),
        ({"dead": [-1]}, r"\[sim\] dead = \[-1\]: expected a list of taxel ids, whole numbers from 0 to 4294967295"),
        ({"dead": [[16]]}, r"\[sim\] dead = \[\[16\]\]: expected a list of taxel ids"),
        ({"missing_modules": "can0:5"}, r"\[sim\] missing_modules = \"can0:5\": expected a list of modules"),
        ({"seed": 1.5}, r"\[sim\] seed = 1.5: expected a whole number"),
        ({"seed": 2**70}, r"\[sim\] seed = 1180591620717411303424: expected a whole number"),
        ({"noize": 1}, r"\[sim\] key = noize: expected one of frame_rate_hz, cover_mm"),
        ({5: 1}, r"\[sim\] key = 5: expected one of frame_rate_hz"),
    ],
)
def test_a_wrong_sim_override_names_its_key_and_what_it_takes(overrides, message):
    # As a user gets them wrong: text for a number, None, NaN, a number for a list, a list for
    # a number, a key misspelt. Each message names the key, never a column of some JSON text.
    for call in (lambda: skin.read_sim_config(None, overrides), lambda: SkinBridge(FIXTURES / "forearm" / "layout.json", response=overrides)):
        with pytest.raises(skin.ConfigError, match=message) as caught:
            call()
        assert "column" not in str(caught.value)
    # numpy's numbers are numbers.
    assert skin.read_sim_config(None, {"noise": np.float32(2.5), "seed": np.int64(7), "dead": (16, np.uint32(17))})["dead"] == [16, 17]


def test_a_press_is_checked_when_it_is_scripted():
    bridge, kit, model, data = scene(tools=("sphere", "hand"))
    top, up = [0, 0.18, 0.08], [0, 0, 1]
    kit.press("sphere", top, up, 5.0, start=1.0, duration=1.0)
    for kwargs, message in (
        (dict(force=-1.0), "force = -1.0: newtons, 0 or more"),
        (dict(force=float("nan")), "force = nan"),
        (dict(normal=[0, 0, 0]), "each normal of non-zero length"),
        (dict(point=[0, float("nan"), 0]), "must be finite"),
        (dict(duration=0.0), "duration = 0.0"),
        (dict(ramp=0.0), "ramp = 0.0"),
        (dict(ramp=0.8), "ramp = 0.8: seconds, more than 0 and at most half the duration"),
        (dict(start=1.5), "overlaps its action at 1-2 s"),
        (dict(fingers=["index"]), "fingers are for a hand, this is a sphere"),
    ):
        args = dict(tool="sphere", point=top, normal=up, force=5.0, start=3.0, duration=1.0)
        args.update(kwargs)
        extra = {k: args.pop(k) for k in ("ramp", "fingers") if k in args}
        with pytest.raises(ValueError, match=message.replace("(", r"\(")):
            kit.press(args["tool"], args["point"], args["normal"], args["force"], args["start"], args["duration"], **extra)
    with pytest.raises(ValueError, match="fingers = 'index'"):
        kit.press("hand", top, up, 5.0, 3.0, 1.0, fingers="index")
    with pytest.raises(ValueError, match="fingers = \\['indx'\\]"):
        kit.press("hand", top, up, 5.0, 3.0, 1.0, fingers=["indx"])
    loop = SkinLoop(model, data, bridge, skin.Session.from_config(CONFIG), control=kit.control)
    loop.run(0.5)
    with pytest.raises(ValueError, match="starts at 0.2 s, the simulation is at 0.5"):
        kit.press("hand", top, up, 5.0, 0.2, 1.0)
    with pytest.raises(ValueError, match="seconds = -1"):
        loop.run(-1)


def test_the_loop_refuses_what_does_not_fit():
    bridge, kit, model, data = scene()
    other = skin.Session.from_layout(skin.read_layout(FIXTURES / "hex_patch" / "layout.json"))
    with pytest.raises(ValueError, match="is not the bridge's"):
        SkinLoop(model, data, bridge, other)
    model.opt.timestep = 0.003
    with pytest.raises(ValueError, match="the model's timestep is 0.003 s but the skin was attached for 0.05 s frames"):
        SkinLoop(model, data, bridge, skin.Session.from_config(CONFIG))
    with pytest.raises(RuntimeError, match=r"Kit.bind\(model, data\) first"):
        Kit(bare_robot(bridge.layout)).control()


def test_a_diverging_simulation_is_an_error_not_frames_from_the_past(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # MuJoCo writes its warning to MUJOCO_LOG.TXT here
    bridge, kit, model, data = scene()
    loop = SkinLoop(model, data, bridge, skin.Session.from_config(CONFIG))
    loop.run(0.2)
    data.qvel[:] = 1e30  # MuJoCo resets the data to its start
    with pytest.raises(skin.SessionError, match="diverged at t = 0.2"):
        loop.run(0.1)


# --- the loop's history of events: bounded, and nothing lost to the bound ---------------------


def three_presses():
    """The forearm pressed by the ball three times (1.5 s, 3.0 s, 4.5 s), to run for 6 s."""
    bridge, kit, model, data = scene()
    for k in range(3):
        kit.press("sphere", [0.0, 0.18, 0.08], [0, 0, 1], 8.0, start=1.5 + 1.5 * k, duration=1.0)
    return bridge, kit, model, data


def test_a_bounded_history_keeps_the_latest_events_and_loses_none_to_its_readers():
    bridge, kit, model, data = three_presses()
    bound = 2
    read, history = [], []

    def control(l):
        kit.control()
        history.append(len(l.events))
        if round(l.time / model.opt.timestep) % 300 == 0:  # now and then: many events between
            read.extend(l.new_events())

    loop = SkinLoop(model, data, bridge, skin.Session.from_config(CONFIG), control=control, max_events=bound)
    assert loop.events.maxlen == bound
    # run() collects its own stretch: each of these is longer than the history.
    stretches = [loop.run(3.7), loop.run(2.3), loop.finish()]
    read.extend(loop.new_events())
    every = [e for s in stretches for e in s]
    assert [len(s) > bound for s in stretches[:2]] == [True, True], [len(s) for s in stretches]
    found = touches(every)
    assert len(found) == 3 and all(t["end"] is not None and t["class"] == "non_hand" for t in found), found
    assert read == every  # new_events() saw every one, in order
    assert max(history) <= bound and list(loop.events) == every[-bound:]
    assert loop.events_dropped == len(every) - bound


def test_the_default_history_is_bounded_and_none_keeps_every_event():
    bridge, kit, model, data = three_presses()
    loop = SkinLoop(model, data, bridge, skin.Session.from_config(CONFIG), control=kit.control, max_events=None)
    every = loop.run(6.0) + loop.finish()
    assert len(every) > 6 and list(loop.events) == every and loop.events_dropped == 0
    # Its first call: the events since the loop began, as the history holds them.
    assert loop.new_events() == every and loop.new_events() == []
    assert SkinLoop(model, data, bridge, skin.Session.from_config(CONFIG)).events.maxlen == MAX_EVENTS


def test_a_history_of_no_events_still_delivers_them():
    bridge, kit, model, data = three_presses()
    loop = SkinLoop(model, data, bridge, skin.Session.from_config(CONFIG), control=kit.control, max_events=0)
    assert loop.new_events() == []
    every = loop.run(6.0) + loop.finish()
    assert len(loop.events) == 0 and loop.events_dropped == len(every) > 0
    assert loop.new_events() == every


@pytest.mark.parametrize("bad", [-1, 1.5, True, "10"])
def test_a_bad_max_events_is_named(bad):
    bridge, kit, model, data = scene()
    with pytest.raises(skin.ArrayError, match=f"max_events = {bad!r}: a number of events, 0 or more"):
        SkinLoop(model, data, bridge, skin.Session.from_config(CONFIG), max_events=bad)


# --- other layouts, and a URDF, checked the same way --------------------------------------


def press_a_central_taxel(bridge, spec, body_of, session, contact="hull"):
    """A 2 cm ball pressed with 3, 6 and 12 N on a taxel with many neighbours near each link's
    middle: per link and force (contacts, centroid error m, summed pressure)."""
    kit = Kit(spec)
    kit.add_sphere(radius=0.02)
    bridge.attach(spec, bodies=body_of, contact=contact)
    model = spec.compile()
    data = mujoco.MjData(model)
    kit.bind(model, data)
    forces = [3.0, 6.0, 12.0]
    plan = []
    t = 1.5
    for k, link in enumerate(bridge.layout.links):
        p, n = link.positions, link.normals
        d = np.linalg.norm(p[:, None] - p[None], axis=2)
        np.fill_diagonal(d, 1.0)
        pitch = np.median(d.min(axis=1))
        near = (d < 1.6 * pitch).sum(axis=1)
        candidates = np.flatnonzero(near >= np.percentile(near, 75))
        i = candidates[np.argmin(np.linalg.norm(p[candidates] - p.mean(axis=0), axis=1))]
        for f in forces:
            kit.press("sphere", p[i], n[i], f, start=t, duration=1.2, body=(body_of or {}).get(link.name, link.name))
            plan.append((k, f, t + 0.8))
            t += 1.5
    loop = SkinLoop(model, data, bridge, session, control=kit.control)
    results = []

    def sample(l):
        for k, f, at in plan:
            if abs(l.frame.time - at) < 1e-3:
                body = model.body((body_of or {}).get(bridge.links[k], bridge.links[k])).id
                contacts = l.session.contacts(k)
                found = contact_on_surface(model, data, body)
                # The contact point in the link's frame, as the session's centroids are.
                rot = data.xmat[body].reshape(3, 3)
                local = rot.T @ (found[0] - data.xpos[body]) if found else None
                err = np.linalg.norm(np.array(contacts[0].centroid) - local) if contacts and found else np.inf
                results.append((k, f, len(contacts), err, sum(c.mean_pressure * len(c.taxels) for c in contacts)))

    loop.run(t + 0.2, until=on_frames(loop, sample))
    return results


def check_presses(results, links):
    assert len(results) == 3 * links
    for k in range(links):
        mine = [r for r in results if r[0] == k]
        assert all(r[2] == 1 for r in mine), mine
        assert all(r[3] < 0.003 for r in mine), mine
        assert mine[0][4] < mine[1][4] < mine[2][4], mine


OTHER_LAYOUTS = ["cyskin/ur10e_link1_patch1.json", "cyskin/hexagon_patch_zwick.json", "icub/left_forearm_V2.txt", "icub/torso.txt"]


@pytest.mark.parametrize("name", OTHER_LAYOUTS)
def test_real_layouts_are_simulated_as_the_fixture_is(name):
    path = SHARED_DATA / name
    if not path.exists():
        pytest.skip(f"{path} is absent (the real third-party data beside the project)")
    layout = skin.read_layout(path)
    bridge = SkinBridge(layout)
    results = press_a_central_taxel(bridge, bare_robot(layout), None, skin.Session.from_layout(layout))
    check_presses(results, len(layout))


URDF = """<robot name="two_pads">
  <link name="base"/>
  <link name="upper"><inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="0.05 0.0375 -0.01"/><geometry><box size="0.14 0.11 0.02"/></geometry></collision></link>
  <link name="lower"><inertial><mass value="0.5"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="0 0 0.01"/><geometry><box size="0.07 0.07 0.02"/></geometry></collision></link>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="upper"/><origin xyz="0 0 0.3"/><axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="50" velocity="1"/></joint>
  <joint name="elbow" type="revolute"><parent link="upper"/><child link="lower"/><origin xyz="0.3 0 0" rpy="1.5707963 0 0"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="50" velocity="1"/></joint>
  <sensor name="upper_pad" update_rate="50"><parent link="upper"/><origin xyz="0 0 0" rpy="0 0 0"/>
    <tactile><array rows="16" cols="12" size="0.006 0.006" spacing="0.007 0.007"/></tactile></sensor>
  <sensor name="lower_pad" update_rate="50"><parent link="lower"/><origin xyz="0 0 0.02" rpy="0 0 0"/>
    <tactile><array rows="10" cols="10" size="0.005 0.005" spacing="0.006 0.006" offset="0.027 0.027"/></tactile></sensor>
</robot>
"""


@pytest.mark.parametrize("contact", ["hull", "model"])
def test_a_urdf_with_tactile_sensors_is_robot_and_skin_at_once(tmp_path, contact):
    # One file gives MuJoCo the robot (its importer) and skin the taxels (urdf_tactile): each
    # link's skin lands on the body of its name, touched on the cover the bridge adds ("hull")
    # or on the URDF's own collision boxes under the pads ("model").
    path = tmp_path / "two_pads.urdf"
    path.write_text(URDF)
    layout = skin.read_layout(path)
    assert layout.names == ["upper", "lower"]
    bridge = SkinBridge(layout)
    results = press_a_central_taxel(bridge, robot_from_urdf(path), None, skin.Session.from_layout(layout), contact=contact)
    check_presses(results, 2)


def test_the_stress_at_the_taxels_adds_up_to_the_force():
    # Stress times the area each taxel stands for, summed over the skin: the press's force (the
    # cover's kernel loses a few percent at its cut and to its sampling).
    bridge, kit, model, data = scene()
    link = bridge.layout[0]
    i = inside_a_module(bridge.layout)
    surface = bridge.surface(0)
    nearest = np.argmin(((surface.points[:, None] - link.positions[None]) ** 2).sum(axis=2), axis=1)
    area = np.bincount(nearest, weights=surface.areas, minlength=len(link))
    forces = [4.0, 10.0]
    for k, f in enumerate(forces):
        kit.press("sphere", link.positions[i], link.normals[i], f, start=1.5 + 1.5 * k, duration=1.2)
    loop = SkinLoop(model, data, bridge, skin.Session.from_config(CONFIG), control=kit.control)
    total = []

    def sample(l):
        for k in range(len(forces)):
            if abs(l.frame.time - (1.5 + 1.5 * k + 0.8)) < 1e-3:
                total.append((l.frame.stress[0] * area).sum())

    loop.run(4.5, until=on_frames(loop, sample))
    for t, f in zip(total, forces):
        assert 0.85 * f < t < 1.15 * f, (t, f)


def test_a_press_with_no_force_reads_nothing():
    bridge, kit, model, data = scene()
    kit.press("sphere", [0, 0.18, 0.08], [0, 0, 1], 0.0, start=1.5, duration=1.0)
    loop = SkinLoop(model, data, bridge, skin.Session.from_config(CONFIG), control=kit.control)
    stress = []
    loop.run(3.0, until=on_frames(loop, lambda l: stress.append(l.frame.stress[0].max())))
    assert max(stress) < 1.0 and touches(loop.events) == []


def test_a_contact_away_from_the_skin_is_not_felt(tmp_path):
    # The URDF's upper link: its pad on top of a box; a ball pressed on the box's underside,
    # 2 cm from the pad, is a contact on the link's body but not on its skin.
    path = tmp_path / "two_pads.urdf"
    path.write_text(URDF)
    layout = skin.read_layout(path)
    bridge = SkinBridge(layout)
    bridge, kit, model, data = scene(bridge=bridge, spec=robot_from_urdf(path), contact="model")
    kit.press("sphere", [0.05, 0.04, -0.02], [0, 0, -1], 8.0, start=1.5, duration=1.0, body="upper")
    kit.press("sphere", [0.05, 0.04, 0.0], [0, 0, 1], 8.0, start=3.0, duration=1.0, body="upper")
    loop = SkinLoop(model, data, bridge, skin.Session.from_layout(layout), control=kit.control)
    upper = model.body("upper").id
    under = []
    loop.run(2.2, until=on_frames(loop, lambda l: under.append(contact_on_surface(model, data, upper))))
    assert under[-1] is not None  # the ball is on the box
    events = loop.run(2.5) + loop.finish()
    found = touches(loop.events)
    assert len(found) == 1 and found[0]["start"] > 3.0, found


def test_links_of_a_bare_robot_lie_apart():
    # The fixture arm: forearm and wrist, each in its own frame; side by side, a press on the
    # wrist is felt by the wrist only, through the arm's bus map.
    config = FIXTURES / "arm" / "run.toml"
    bridge, kit, model, data = scene(config)
    wrist = bridge.layout["wrist"]
    i = int(np.argmin(np.abs(wrist.positions[:, 0]) + np.abs(wrist.positions[:, 1] - 0.08)))
    kit.press("sphere", wrist.positions[i], wrist.normals[i], 8.0, start=1.5, duration=1.0, body="wrist")
    loop = SkinLoop(model, data, bridge, skin.Session.from_config(config), control=kit.control)
    loop.run(3.0)
    found = touches([*loop.events, *loop.finish()])
    assert [t["link"] for t in found] == ["wrist"], found


def test_falling_polarity_needs_a_rest_near_full_scale():
    layout = skin.read_layout(FIXTURES / "forearm" / "layout.json")
    with pytest.raises(ValueError, match="rest = 200 with falling polarity"):
        SkinBridge(layout, polarity="falling")
    bridge = SkinBridge(layout, polarity="falling", response={"rest": 255, "full_scale": 255, "rest_spread": 0, "noise": 0})
    counts = [bridge.response.counts([np.full(715, s)])[0] for s in (0.0, 1e4, 1e5, 1e7)]
    assert np.all(counts[0] == 255) and np.all(counts[1] < 255)
    assert np.all(counts[2] < counts[1]) and counts[3].min() >= 0


def test_mesh_objects_get_a_distance_field_for_the_sensor():
    bridge = SkinBridge.from_config(CONFIG)
    spec = bare_robot(bridge.layout)
    cube = spec.add_mesh(name="cube")
    corners = [x for p in np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).T.reshape(-1, 3) * 0.01 for x in p]
    cube.uservert = corners
    box = spec.worldbody.add_body(name="box", pos=[0.5, 0, 0])
    box.add_geom(type=mujoco.mjtGeom.mjGEOM_MESH, meshname="cube")
    # A mesh only shown (no geom of it collides) needs no field: it cannot touch the skin.
    shown = spec.add_mesh(name="shown")
    shown.uservert = corners
    g = box.add_geom(type=mujoco.mjtGeom.mjGEOM_MESH, meshname="shown")
    g.contype = g.conaffinity = 0
    bridge.attach(spec)
    assert cube.needsdf and not shown.needsdf and not spec.mesh("skin_forearm_surface").needsdf


# --- forces the scene cannot hold ------------------------------------------------------------


def test_a_press_beyond_what_the_scene_holds_is_refused_naming_the_limit():
    # MuJoCo's soft contact holds a tool as deep as the cover (5 mm) up to a force that grows
    # with its mass, not its size: 0.2 kg balls of 15 to 30 mm alike; 1 kg holds five times more.
    for radius in (0.015, 0.02, 0.03):
        _, kit, _, _ = scene(sphere_radius=radius)
        assert kit.force_limit("sphere") == pytest.approx(0.2 * HULL_DEPTH / (0.05 * 0.03**2))  # 22.2 N
    bridge = SkinBridge.from_config(CONFIG)
    spec = bare_robot(bridge.layout)
    kit = Kit(spec)
    kit.add_sphere(mass=1.0)
    kit.add_bar(radius=0.015)
    kit.add_hand()
    # Scripted before the model is known, checked when it is.
    kit.press("sphere", [0, 0.18, 0.08], [0, 0, 1], 100.0, start=1.5, duration=1.0)
    kit.press("bar", [0, 0.18, 0.08], [0, 0, 1], 300.0, start=1.5, duration=1.0)
    bridge.attach(spec)
    model = spec.compile()
    with pytest.raises(skin.ArrayError, match=r"bar: force = 300 N at 1.5 s: more than this scene holds; beyond 33.3 N"):
        kit.bind(model, mujoco.MjData(model))
    assert kit.force_limit("sphere") == pytest.approx(111.1, abs=0.1) and kit.force_limit("bar") == pytest.approx(33.3, abs=0.1)
    # The hand's flesh (its solimp, 2 cm) gives as well as the cover.
    assert kit.tools["hand"].limit_depth == pytest.approx(HULL_DEPTH + 0.02) and kit.force_limit("hand") > 60.0
    with pytest.raises(ValueError, match=r"sphere: force = 112 N at 3 s: .* beyond 111.1 N the sphere \(1 kg\) sinks into the skin deeper than a skin gives \(5 mm\)"):
        kit.press("sphere", [0, 0.18, 0.08], [0, 0, 1], 112.0, start=3.0, duration=1.0)
    kit.press("sphere", [0, 0.18, 0.08], [0, 0, 1], 111.0, start=3.0, duration=1.0)
    with pytest.raises(KeyError, match="no tool 'ball'"):
        kit.force_limit("ball")


def box_and_ball(cover: str, ball: str, timestep=0.002):
    """A fixed box that carries a skin (its sensor surface, a stand-in) and a free 0.5 kg ball on
    it, no gravity, with the contact attributes given."""
    return mujoco.MjModel.from_xml_string(f"""<mujoco><option timestep="{timestep}" gravity="0 0 0"/><worldbody>
      <body name="link"><geom name="skin_link_surface" type="box" size=".001 .001 .001" contype="0" conaffinity="0"/>
        <geom name="cover" type="box" size=".1 .1 .02" {cover}/></body>
      <body name="ball" pos="0 0 .05"><freejoint/><geom name="ball" type="sphere" size=".03" mass=".5" {ball}/></body>
    </worldbody></mujoco>""")


@pytest.mark.parametrize(
    "cover, ball, depth",
    [
        # The cover's own softness (a higher priority), as attach makes it.
        ('priority="1" solref=".03 1" solimp=".5 .95 .005 .5 2"', "", HULL_DEPTH),
        # Mid-way up a wider impedance curve.
        ('priority="1" solref=".03 1" solimp=".3 .95 .02 .4 3"', "", HULL_DEPTH),
        # Equal priorities: mixed by solmix.
        ('solref=".03 1" solimp=".5 .95 .005 .5 2" solmix="3"', 'solref=".01 1" solimp=".9 .99 .002 .5 2"', HULL_DEPTH),
        # A time constant under two steps: MuJoCo's refsafe lengthens it.
        ('priority="1" solref=".003 1" solimp=".5 .95 .005 .5 2"', "", HULL_DEPTH),
        # Stiffness and damping given directly.
        ('priority="1" solref="-20000 -200" solimp=".5 .95 .005 .5 2"', "", HULL_DEPTH),
        # A soft tool (higher priority, as the kit hand's flesh): its own give adds to the cover's.
        ("", 'priority="2" solref=".05 1" solimp=".2 .95 .01 .5 2"', HULL_DEPTH + 0.01),
    ],
)
def test_the_holding_force_is_mujocos_contact_at_rest(cover, ball, depth):
    # Pushed with the holding force, the ball settles exactly as deep as a skin allows.
    model = box_and_ball(cover, ball)
    data = mujoco.MjData(model)
    tool, skin_geom = model.geom("ball").id, model.geom("cover").id
    force, allowed = holding_force(model, 0.5, tool, skin_geom)
    assert allowed == pytest.approx(depth) == allowed_depth(model, skin_geom, tool)
    body = model.body("ball").id
    for _ in range(3000):
        data.xfrc_applied[body, 2] = -force
        mujoco.mj_step(model, data)
    assert data.ncon == 1 and -data.contact.dist[0] == pytest.approx(depth, rel=1e-3)


def test_the_ball_sinks_as_deep_as_the_cover_at_its_force_limit():
    # Just under the limit the ball stays within the cover, and nothing is reported; a push a
    # little past it sinks it deeper, reported.
    bridge, kit, model, data = scene()
    limit = kit.force_limit("sphere")
    top, up = np.array([0, 0.18, 0.08]), np.array([0, 0, 1.0])
    kit.press("sphere", top, up, 0.98 * limit, start=1.5, duration=1.2)
    kit.press("sphere", top, up, 0.98 * limit, start=3.0, duration=1.2)
    ball = model.body("sphere").id
    deepest = {}

    def control(loop):
        kit.control(loop)
        if 3.0 < loop.time < 4.0:
            data.xfrc_applied[ball, :3] -= 0.12 * limit * up  # the user's own push, past the kit
        if data.ncon:
            k = int(loop.time > 3.0)
            deepest[k] = max(deepest.get(k, 0.0), -data.contact.dist.min())

    loop = SkinLoop(model, data, bridge, skin.Session.from_config(CONFIG), control=control)
    with pytest.warns(skin.SkinWarning, match=r"sphere_ball is 5.\d mm into link 'forearm', deeper than a skin gives there \(5 mm\)"):
        loop.run(4.5)
    # Past the end of the cover's impedance curve the depth grows with the force: 1.1 times the
    # limit, 1.1 times as deep.
    assert 0.97 * HULL_DEPTH < deepest[0] <= HULL_DEPTH and deepest[1] == pytest.approx(1.1 * HULL_DEPTH, rel=0.02), deepest
    [press] = loop.overpresses
    assert (press.link, press.geom, press.through) == ("forearm", "sphere_ball", False)
    assert 3.0 < press.start < press.end < 4.1 and press.depth == pytest.approx(deepest[1]) and press.allowed == HULL_DEPTH


def test_a_tool_pushed_through_the_forearm_is_reported():
    # The user's own controller pushes the kit's ball with 100 N (it sinks past the cover, its
    # centre under the skin, and comes back) and then with 300 N (it goes through the forearm):
    # each is warned of and recorded, the second as gone through.
    bridge, kit, model, data = scene()
    top, up = np.array([0, 0.18, 0.08]), np.array([0, 0, 1.0])
    kit.press("sphere", top, up, 5.0, start=1.5, duration=1.2)
    kit.press("sphere", top, up, 5.0, start=3.0, duration=1.2)
    ball = model.body("sphere").id

    def control(loop):
        kit.control(loop)
        if 1.8 < loop.time < 2.5 or 3.3 < loop.time < 4.0:
            data.xfrc_applied[ball, :3] -= (100.0 if loop.time < 3.0 else 300.0) * up

    loop = SkinLoop(model, data, bridge, skin.Session.from_config(CONFIG), control=control)
    with pytest.warns(skin.SkinWarning) as caught:
        loop.run(4.5)
    messages = [str(w.message) for w in caught if issubclass(w.category, skin.SkinWarning)]
    assert any("went through link 'forearm'" in m for m in messages), messages
    sunk, through = loop.overpresses
    assert not sunk.through and sunk.depth > 0.02 and 1.8 < sunk.start < sunk.end < 2.7
    assert through.through and through.depth > 0.04 and 3.3 < through.start < 4.0


def test_timesteps_a_skin_cannot_run_at_are_refused():
    layout = skin.read_layout(FIXTURES / "forearm" / "layout.json")
    for bad in (0.0, -0.002, float("nan"), float("inf"), 0.02, 1e-7):
        for make in (lambda: bare_robot(layout, timestep=bad), lambda: two_joint_arm("forearm", timestep=bad)):
            with pytest.raises(skin.ArrayError, match=f"timestep = {bad}: seconds from 1e-05 to {MAX_TIMESTEP:g}"):
                make()
    with pytest.raises(ValueError, match="timestep = 'fast': seconds, a number"):
        bare_robot(layout, timestep="fast")
    # A robot's own spec, checked when the skin is attached and when the model is bound.
    bridge = SkinBridge(layout)
    spec = bare_robot(layout)
    spec.option.timestep = -0.002
    with pytest.raises(skin.ArrayError, match="the spec's option.timestep = -0.002: seconds"):
        bridge.attach(spec)
    bridge, kit, model, data = scene()
    model.opt.timestep = float("nan")
    with pytest.raises(skin.ArrayError, match="the model's opt.timestep = nan: seconds"):
        SkinLoop(model, data, bridge, skin.Session.from_config(CONFIG))
    assert bare_robot(layout, timestep=MAX_TIMESTEP).option.timestep == MAX_TIMESTEP


# --- the force calibration rig (skin.sim.ForceRig) -------------------------------------------


def rig_config(tmp_path, calibration):
    """The fixture's run.toml, its paths made absolute, naming `calibration` as its [force]."""
    import re

    text = CONFIG.read_text()
    text = re.sub(
        r'^(layout|busmap|classifier|segmenter|truth|cache) = "([^"]+)"',
        lambda m: f'{m[1]} = "{(CONFIG.parent / m[2]).resolve()}"',
        text,
        flags=re.M,
    )
    text = re.sub(r"^\[force\][^\[]*", "", text, flags=re.M)
    path = tmp_path / "run.toml"
    path.write_text(text + f'\n[force]\ncalibration = "{calibration}"\n')
    return path


@pytest.fixture(scope="module")
def calibrated_rig(tmp_path_factory):
    """The fixture forearm calibrated by skin.calibrate_force from the rig's files: 30 presses
    of ball, bar and plate (1-30 N) at half of its taxels."""
    from skin.sim import ForceRig

    tmp = tmp_path_factory.mktemp("rig")
    rig = ForceRig(CONFIG)
    taxels = np.random.default_rng(5).permutation(len(rig.positions))
    half = (taxels[: len(taxels) // 2], taxels[len(taxels) // 2 :])
    run = rig.record(rig.script(30, seed=1, places=half[0]), tmp / "cal.txt", tmp / "cal.csv")
    fit = skin.calibrate_force(CONFIG, tmp / "cal.csv", recording=tmp / "cal.txt", output=tmp / "force.json")
    return rig, half, run, fit, rig_config(tmp, tmp / "force.json"), tmp


def test_the_rig_writes_what_calibrate_force_reads(calibrated_rig):
    rig, _, run, fit, _, tmp = calibrated_rig
    # The load file: a sample per frame of the recording, on its clock; a point where pressed.
    rec = skin.read_recording(tmp / "cal.txt")
    table = np.genfromtxt(tmp / "cal.csv", delimiter=",", names=True)
    assert len(rec) == len(table) == run.frames
    np.testing.assert_allclose(table["time_s"], rec.times, atol=1e-6)
    pressed = table["force_n"] > 0
    assert np.isnan(table["x_m"][~pressed]).all() and not np.isnan(table["x_m"][pressed]).any()
    assert 25 <= table["force_n"].max() <= 31
    # The fit: the [sim] response's curve (4095 counts, 150 kPa) within 15%, every press explained.
    assert abs(fit["curve"]["full_scale"] / 4095 - 1) < 0.15, fit["curve"]
    assert abs(fit["curve"]["half_scale_kpa"] / 150 - 1) < 0.15, fit["curve"]
    assert fit["fit"]["r_squared"] > 0.99 and len(fit["fit"]["presses"]) == 30
    assert fit["name"] == "forearm" and len(fit["gains"]) == len(fit["ids"]) == len(rig.positions)
    on_file = json.loads((tmp / "force.json").read_text())
    assert on_file["format"] == "skin-force/1" and on_file["links"][0]["gains"] == fit["gains"]


def test_a_calibrated_session_reads_held_out_presses_in_newtons(calibrated_rig):
    from skin.sim import read_with

    rig, half, _, _, config, tmp = calibrated_rig
    presses = rig.script(12, seed=100, forces=(2.0, 20.0), places=half[1])
    run = rig.record(presses, tmp / "held.txt", tmp / "held.csv")
    r = read_with(skin.Session.from_config(config), tmp / "held.txt", tmp / "held.csv")
    err = r.relative_error((2.0, 20.0))
    keep = (run.load >= 2.0) & (run.load <= 20.0)
    ideal = np.abs(run.ideal[keep] - run.load[keep]) / run.load[keep]
    assert len(err) > 100
    # Within 12% at the median; no more than 4 points above what a model knowing every taxel's
    # stress would read (the skin's own floor: its taxels sample a contact coarsely), nor 15
    # points at the 95th percentile.
    assert np.median(err) < 0.12, np.median(err)
    assert np.median(err) < np.median(ideal) + 0.04, (np.median(err), np.median(ideal))
    assert np.percentile(err, 95) < np.percentile(ideal, 95) + 0.15, (np.percentile(err, 95), np.percentile(ideal, 95))
    # Where it pressed, across the skin; and the torque is the centre's lever times the force.
    pressed = keep & ~np.isnan(r.cop[:, 0]) & ~np.isnan(r.point[:, 0])
    assert np.median(r.cop_error()[pressed]) < 0.003
    lever = np.cross(r.cop[pressed], r.wrench[pressed])
    np.testing.assert_array_less(np.linalg.norm(r.torque[pressed] - lever, axis=1), 0.1 * np.linalg.norm(r.torque[pressed], axis=1))


def test_a_plate_laid_on_the_skin_is_weighed(calibrated_rig):
    from skin.sim import RigPress, read_with, weight

    rig, half, _, _, config, tmp = calibrated_rig
    places = [i for i in rig.places("plate") if i in set(half[1])][:4]
    presses = [RigPress("plate", tuple(rig.positions[i]), tuple(rig.normals[i]), weight(0.1), 2.0) for i in places]
    run = rig.record(presses, tmp / "plate.txt", tmp / "plate.csv")
    r = read_with(skin.Session.from_config(config), tmp / "plate.txt", tmp / "plate.csv")
    for start, end in run.spans:
        held = (r.times >= start + 0.5) & (r.times < end - 0.5)
        assert abs(np.median(r.load[held]) - 0.980665) < 0.03
        # Read within 10% of what the skin's taxels could tell (`ideal`), and within 30% of its
        # weight: a plate's edge between two rows of taxels is felt by neither.
        read, ideal = np.median(r.force[held]), np.median(run.ideal[held])
        assert abs(read / ideal - 1) < 0.1, (read, ideal)
        assert abs(read / 0.980665 - 1) < 0.3, read


def test_the_rig_refuses_what_it_cannot_do(tmp_path):
    from skin.sim import ForceRig, RigPress

    rig = ForceRig(CONFIG)
    with pytest.raises(skin.UnknownNameError, match="no tool 'hammer'"):
        rig.script(3, tools=("hammer",))
    with pytest.raises(skin.ArrayError, match="forces"):
        rig.script(3, forces=(5.0, 1.0))
    # Not a load file: never overwritten.
    other = tmp_path / "notes.csv"
    other.write_text("mine\n")
    with pytest.raises(skin.ArrayError, match="not replaced"):
        rig.record([RigPress("ball", tuple(rig.positions[0]), tuple(rig.normals[0]), 2.0)], tmp_path / "r.txt", other)
    assert other.read_text() == "mine\n" and not (tmp_path / "r.txt").exists()


def test_calibrate_force_names_what_is_wrong(calibrated_rig, tmp_path):
    _, _, _, _, _, tmp = calibrated_rig
    late = tmp_path / "late.csv"
    late.write_text("time_s,force_n\n1000,0\n1001,5\n")
    with pytest.raises(skin.InputError, match="late.csv: no frame of the input falls within"):
        skin.calibrate_force(CONFIG, late, recording=tmp / "cal.txt")
    with pytest.raises(skin.ArrayError, match="give one of them"):
        skin.calibrate_force(CONFIG, late)
    with pytest.raises(skin.ArrayError, match="link"):
        skin.calibrate_force(CONFIG, tmp / "cal.csv", recording=tmp / "cal.txt", link="elbow")
    keep = tmp_path / "keep.json"
    keep.write_text('{"mine": 1}')
    with pytest.raises(skin.InputError, match="keep.json"):
        skin.calibrate_force(CONFIG, tmp / "cal.csv", recording=tmp / "cal.txt", output=keep)
    assert keep.read_text() == '{"mine": 1}'


def test_a_held_press_keeps_its_force_and_drift_is_still_corrected(calibrated_rig, tmp_path):
    """10 N held 60 s, then nothing for 20 s, the whole skin's rest level rising 0.5 counts a
    second throughout (as temperature moves it): the press keeps its reading (the baseline does
    not learn it away) and, once it is gone, the drift is followed (no touch appears)."""
    from skin.sim import RigPress, read_with

    rig, half, _, _, config, tmp = calibrated_rig
    i = int(rig.places("ball")[len(rig.places("ball")) // 2])
    press = RigPress("ball", tuple(rig.positions[i]), tuple(rig.normals[i]), 10.0, 62.0)
    rig.record([press], tmp_path / "still.txt", tmp_path / "held.csv", settle=1.5, gap=20.0)
    rec = skin.read_recording(tmp_path / "still.txt")
    drifting = rec.values + 0.5 * (rec.times - rec.times[0])[:, None].astype(np.float32)
    skin.write_recording(tmp_path / "held.txt", rec.ids, rec.times, np.rint(drifting))
    session = skin.Session.from_config(config)
    r = read_with(session, tmp_path / "held.txt", tmp_path / "held.csv")
    at = lambda t: int(np.argmin(np.abs(r.times - t)))  # noqa: E731
    start, end = at(5.0), at(61.0)
    assert abs(r.load[start] - 10.0) < 0.1 and abs(r.load[end] - 10.0) < 0.1
    assert r.force[end] >= 0.9 * r.force[start], (r.force[start], r.force[end])
    after = r.times >= 70.0
    assert after.sum() > 150 and (r.load[after] == 0).all()
    assert (r.force[after] == 0).all() and np.isnan(r.cop[after, 0]).all()
