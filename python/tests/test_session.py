"""The session from Python: the same events as `skin run`, frames pushed one by one, contacts,
and a Python callable as its classifier."""

import os

import numpy as np
import pytest

import skin
from conftest import FIXTURES

CONFIG = FIXTURES / "session" / "run.toml"
LOG = FIXTURES / "session" / "session.candump.log"
MODELS = FIXTURES / "models"


def decisions(events):
    return [(e.touch, e["class"], e.probability) for e in events if e.kind == "released"]


def test_events_equal_skin_run(builtin_session_events, cli_session_events):
    assert [e.to_dict() for e in builtin_session_events] == cli_session_events
    assert len(decisions(builtin_session_events)) == 20


def test_events_are_objects_with_the_documented_fields(builtin_session_events):
    first = builtin_session_events[0]
    assert first.kind == "appeared"
    assert first.link == "forearm" and first.touch == 0
    assert isinstance(first.time, float) and len(first.centroid) == 3
    classified = next(e for e in builtin_session_events if e.kind == "classified")
    assert classified["class"] == "hand" and 0 <= classified.probability <= 1
    assert classified.image.shape == (68, 100) and classified.image.dtype == np.uint8
    assert classified.parts and {p["part"] for p in classified.parts} <= {"thumb", "index", "middle", "ring", "pinkie", "palm"}
    # What an event returns is the caller's to change; the event stays as it was.
    classified.parts.append("x")
    assert classified.to_dict() == classified.to_dict() and "x" not in classified.parts
    other = next(e for e in builtin_session_events if e.kind == "classified" and e["class"] == "non_hand")
    assert other.parts == [] and "parts" not in other.to_dict()
    with pytest.raises(AttributeError, match='no field "nope"'):
        first.nope
    assert "appeared" in repr(first)


def conforms(line, typed) -> None:
    """`line` has every key `typed` requires, no key it does not name, values of its types."""
    import typing

    hints = typing.get_type_hints(typed)
    assert typed.__required_keys__ <= line.keys(), (typed.__name__, typed.__required_keys__ - line.keys())
    assert line.keys() <= hints.keys(), (typed.__name__, line.keys() - hints.keys())
    for key, value in line.items():
        hint = hints[key]
        origin = typing.get_origin(hint)
        if origin is typing.Literal:
            assert value in typing.get_args(hint), (key, value)
        elif hint is float:
            assert isinstance(value, (int, float)) and not isinstance(value, bool), (key, value)
        elif hint in (int, str, bool):
            assert type(value) is hint, (key, value)
        elif isinstance(hint, type) and hasattr(hint, "__required_keys__"):
            conforms(value, hint)
        elif origin is list:
            (item,) = typing.get_args(hint)
            for v in value:
                if hasattr(item, "__required_keys__"):
                    conforms(v, item)
                else:
                    assert isinstance(v, item), (key, value)
        else:
            raise AssertionError(f"{typed.__name__}[{key!r}]: a type this check does not read: {hint}")


def test_every_event_kind_is_typed_as_skin_events_says(builtin_session_events):
    import typing

    from skin import events as typed

    # The Literal is written once in Python; the Rust session's list is the source it must match.
    assert typed.EVENT_KINDS == tuple(skin._skin.EVENT_KINDS)
    by_kind = {t.__annotations__["event"].__args__[0]: t for t in typing.get_args(typed.EventDict)}
    assert set(by_kind) == set(typed.EVENT_KINDS)
    # Every kind the fixture session, a missing module, a tare and the stitched arm's touch
    # across its joint make (8 of the 11).
    busmap = skin.BusMap.read(FIXTURES / "forearm" / "busmap.toml")
    session = skin.Session.from_config(CONFIG)
    rest = np.full(len(busmap.ids), 100.0)
    more = [e for k in range(25) for e in session.push_bus(rest, 0.05 * k)]
    more += session.push_bus(rest, 1.25, [("can0", 5)])
    session.tare()
    more += session.push_bus(rest, 1.3)
    arm = skin.Session.from_config(FIXTURES / "arm" / "run.toml")
    more += arm.run_log(FIXTURES / "arm" / "touch.candump.log")
    seen = set()
    for event in list(builtin_session_events) + more:
        line = event.to_dict()
        assert event.kind == line["event"] and event.kind in typed.EVENT_KINDS
        conforms(line, by_kind[event.kind])
        seen.add(event.kind)
    assert {"appeared", "classified", "released", "gate", "incomplete", "across_joint", "across_joint_end", "tare"} <= seen


def log_frames():
    layout = skin.read_layout(FIXTURES / "forearm" / "layout.json")
    busmap = skin.BusMap.read(FIXTURES / "forearm" / "busmap.toml")
    return list(skin.read_log(LOG, busmap, layout))


def test_push_can_gives_the_events_of_run_log(builtin_session_events):
    session = skin.Session.from_config(CONFIG)
    events = []
    for frame in log_frames():
        events += session.push_can(frame)
    events += session.finish()
    assert [e.to_dict() for e in events] == [e.to_dict() for e in builtin_session_events]


def test_push_readings_per_link(builtin_session_events):
    frames = log_frames()
    assert all(f.complete for f in frames)
    for form in ("list", "dict", "array"):
        session = skin.Session.from_config(CONFIG)
        events = []
        for f in frames:
            values = f.values
            readings = {"list": values, "dict": {"forearm": values[0]}, "array": values[0]}[form]
            events += session.push(readings, f.time)
        events += session.finish()
        assert decisions(events) == decisions(builtin_session_events), form


def test_push_bus_takes_slots_as_a_log_frame_does(builtin_session_events):
    # Each frame of the log, given as the buses' slots: the same decisions as the log.
    layout = skin.read_layout(FIXTURES / "forearm" / "layout.json")
    busmap = skin.BusMap.read(FIXTURES / "forearm" / "busmap.toml")
    where = {int(t): i for i, t in enumerate(layout[0].ids)}
    slot_of = np.array([where[int(t)] for t in busmap.ids])
    session = skin.Session.from_config(CONFIG)
    events = []
    for f in log_frames():
        events += session.push_bus(f.values[0][slot_of], f.time)
    events += session.finish()
    assert decisions(events) == decisions(builtin_session_events)


def test_push_bus_reports_a_missing_module_and_refuses_what_does_not_fit():
    busmap = skin.BusMap.read(FIXTURES / "forearm" / "busmap.toml")
    modules = busmap.modules
    assert len(modules) == 65 and modules[5][:2] == ("can0", 5)
    assert [s for m in modules for s in m[2]] == list(range(len(busmap.ids)))
    session = skin.Session.from_config(CONFIG)
    rest = np.full(len(busmap.ids), 100.0)
    for k in range(25):
        session.push_bus(rest, 0.05 * k)
    events = session.push_bus(rest, 1.25, [("can0", 5)])
    incomplete = [e for e in events if e.kind == "incomplete"]
    assert incomplete and incomplete[0].missing == [{"bus": "can0", "address": 5}]
    assert session.stats["incomplete"] == 1
    with pytest.raises(ValueError, match="no module can0:99"):
        session.push_bus(rest, 1.3, [("can0", 99)])
    with pytest.raises(ValueError, match="714 values, the bus map has 715 slots"):
        session.push_bus(rest[1:], 1.3)
    bad = rest.copy()
    bad[3] = np.nan
    with pytest.raises(ValueError, match=r"slot 3 \(taxel 19\) is NaN"):
        session.push_bus(bad, 1.3)
    with pytest.raises(skin.SessionError, match="bus map"):
        skin.Session.from_layout(skin.read_layout(FIXTURES / "forearm" / "layout.json")).push_bus(rest, 0.0)


def test_the_sim_table_is_read_with_its_defaults(tmp_path):
    defaults = skin.read_sim_config()
    assert skin.read_sim_config(CONFIG) == defaults
    assert defaults["frame_rate_hz"] == 20.0 and defaults["missing_modules"] == []
    config = tmp_path / "run.toml"
    config.write_text('layout = "l.json"\n[sim]\nnoise = 3\ndead = [16]\n')
    sim = skin.read_sim_config(config)
    assert sim["noise"] == 3.0 and sim["dead"] == [16] and sim["cover_mm"] == defaults["cover_mm"]
    config.write_text('layout = "l.json"\n[sim]\ndropout = 2\n')
    with pytest.raises(skin.ConfigError, match=r"\[sim\] dropout = 2"):
        skin.read_sim_config(config)


def test_contacts_of_the_last_frame():
    frames = log_frames()
    session = skin.Session.from_config(CONFIG)
    appeared = None
    for f in frames:
        events = session.push_can(f)
        appeared = next((e for e in events if e.kind == "appeared"), None)
        if appeared:
            break
    assert appeared is not None
    contacts = session.contacts("forearm")
    assert contacts == session.contacts(0)
    assert sum(len(c.taxels) for c in contacts) == appeared.taxels
    biggest = max(contacts, key=lambda c: len(c.taxels))
    np.testing.assert_allclose(biggest.centroid, appeared.centroid, atol=2e-4 + 0.02 * (len(contacts) > 1))
    assert biggest.peak_pressure >= biggest.mean_pressure > 0
    with pytest.raises(skin.ArrayError, match="link"):
        session.contacts("elbow")


def handsnet_in_onnxruntime():
    ort = pytest.importorskip("onnxruntime")
    net = ort.InferenceSession(str(MODELS / "handsnet.onnx"), providers=["CPUExecutionProvider"])
    calls = []

    def classify(image):
        calls.append(image.shape)
        # The card: input [N, 1, 68, 100], pixel values divided by 255.
        x = image.astype(np.float32)[None, None] / 255.0
        return net.run(None, {"image": x})[0][0]

    return classify, calls


def test_a_python_classifier_in_onnxruntime_decides_as_the_builtin_model(builtin_session_events):
    classify, calls = handsnet_in_onnxruntime()
    session = skin.Session.from_config(CONFIG, classifier=classify)
    assert session.classes == ["hand", "non_hand"]
    events = session.run_log(LOG)
    ours, builtin = decisions(events), decisions(builtin_session_events)
    assert len(ours) == 20 and calls and all(s == (68, 100) for s in calls)
    assert [(t, c) for t, c, _ in ours] == [(t, c) for t, c, _ in builtin]
    # onnxruntime and tract agree to float rounding.
    np.testing.assert_allclose([p for *_, p in ours], [p for *_, p in builtin], atol=2e-3)


def test_a_python_segmenter_gives_the_parts():
    def palm_everywhere(image):
        return np.where(image > 0, 6, 0).astype(np.uint8)

    session = skin.Session.from_config(CONFIG, segmenter=palm_everywhere)
    events = session.run_log(LOG)
    hands = [e for e in events if e.kind == "classified" and e["class"] == "hand"]
    assert hands and all({p["part"] for p in e.parts} == {"palm"} for e in hands)


def test_an_exception_in_the_callable_reaches_the_caller_with_the_frame():
    class Boom(RuntimeError):
        pass

    def classify(image):
        raise Boom("the model is not loaded")

    session = skin.Session.from_config(CONFIG, classifier=classify)
    with pytest.raises(Boom, match="the model is not loaded") as info:
        session.run_log(LOG)
    notes = " ".join(getattr(info.value, "__notes__", []))
    assert "frame at 1.150 s" in notes and "touch 0" in notes and "forearm" in notes, notes


def test_a_classifier_with_the_wrong_outputs_is_a_model_error():
    session = skin.Session.from_config(CONFIG, classifier=lambda image: [0.5, 0.3, 0.2])
    with pytest.raises(skin.ModelError):
        session.run_log(LOG)
    session = skin.Session.from_config(CONFIG, classifier=lambda image: ["a", "b"])
    with pytest.raises(skin.ArrayError, match="the Python classifier's answer: dtype <U1"):
        session.run_log(LOG)


def test_a_session_from_code_with_a_python_classifier():
    layout = skin.read_layout(FIXTURES / "forearm" / "layout.json")
    busmap = skin.BusMap.read(FIXTURES / "forearm" / "busmap.toml")
    classify, _ = handsnet_in_onnxruntime()
    session = skin.Session.from_layout(
        layout, busmap=busmap, classifier=classify, gate={"hand": "comply", "non_hand": "stop"}
    )
    assert session.links == ["forearm"] and session.taxels == [715]
    events = session.run_log(LOG)
    assert len(decisions(events)) == 20
    assert {e.action for e in events if e.kind == "gate"} == {"comply", "stop", "resume"}
    untracked = skin.Session.from_layout(layout, busmap=busmap)
    events = untracked.run_log(LOG)
    released = [e for e in events if e.kind == "released"]
    assert len(released) == 20
    # Undecided: no class in events.jsonl, None here.
    assert released[0]["class"] is None and released[0].probability is None and "class" not in released[0].to_dict()
    assert not [e for e in events if e.kind == "classified"]


def test_a_recording_runs_as_skin_run_recording():
    layout = skin.read_layout(FIXTURES / "forearm" / "layout.json")
    session = skin.Session.from_layout(layout)
    events = session.run_recording(FIXTURES / "forearm" / "touches.txt")
    assert [e for e in events if e.kind == "released"]
    assert session.stats["frames"] == len(skin.read_recording(FIXTURES / "forearm" / "touches.txt"))


def rss_kb() -> int:
    with open(f"/proc/{os.getpid()}/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    raise RuntimeError("no VmRSS")


@pytest.mark.skipif(not os.path.exists("/proc/self/status"), reason="resident memory is read from /proc (Linux)")
def test_memory_is_stable_over_100k_pushes():
    # A Python classifier (the callable's path: image out, scores in, every decision) on the
    # fixture session's frames, replayed 160 times over: 3,200 touches and their events.
    layout = skin.read_layout(FIXTURES / "forearm" / "layout.json")
    session = skin.Session.from_layout(layout, classifier=lambda image: np.array([0.9, 0.1]))
    frames = log_frames()
    n = len(frames)
    readings = [f.values for f in frames]
    period = frames[-1].time - frames[0].time + 0.05
    t = 0.0
    samples = {}
    kinds = {}
    for i in range(100_000):
        lap, k = divmod(i, n)
        t = frames[k].time - frames[0].time + lap * period
        for event in session.push(readings[k], t):
            kinds[event.kind] = kinds.get(event.kind, 0) + 1
        if i + 1 in (10_000, 100_000):
            samples[i + 1] = rss_kb()
    assert session.stats["frames"] == 100_000
    assert kinds["classified"] >= 3000, kinds
    warm, end = samples[10_000], samples[100_000]
    assert end <= warm * 1.10, f"resident memory {warm} kB after 10,000 pushes, {end} kB after 100,000"


def test_contacts_name_their_taxels_by_index_and_by_id():
    layout = skin.read_layout(FIXTURES / "forearm" / "layout.json")
    ids = layout[0].ids
    session = skin.Session.from_config(CONFIG)
    for f in log_frames():
        session.push_can(f)
        contacts = session.contacts(0)
        if contacts:
            break
    assert contacts
    for c in contacts:
        # Indices into the link's taxels (a frame's order), and the ids those taxels have.
        assert c.taxel_ids == [int(ids[i]) for i in c.taxels]
    # The fixture's ids are not its indices: the two cannot be mistaken for each other here.
    assert any(c.taxel_ids != c.taxels for c in contacts)


def test_events_and_contacts_pickle_as_values_and_a_session_says_what_to_pickle(builtin_session_events):
    import copy
    import pickle

    classified = next(e for e in builtin_session_events if e.kind == "classified")
    for event in (builtin_session_events[0], classified):
        again = pickle.loads(pickle.dumps(event))
        assert again == event and again.to_dict() == event.to_dict() and again.kind == event.kind
        assert repr(again) == repr(event)
    np.testing.assert_array_equal(pickle.loads(pickle.dumps(classified)).image, classified.image)
    assert copy.deepcopy(classified).probability == classified.probability
    session = skin.Session.from_config(CONFIG)
    for f in log_frames():
        session.push_can(f)
        if session.contacts(0):
            break
    contact = session.contacts(0)[0]
    assert pickle.loads(pickle.dumps(contact)) == contact and copy.copy(contact) == contact
    with pytest.raises(TypeError, match=r"a Session cannot be pickled: .*to_dict\(\)"):
        pickle.dumps(session)
    with pytest.raises(TypeError, match="a Session cannot be pickled"):
        copy.deepcopy(session)


def test_finishing_before_the_baseline_is_learned_warns_and_releases_nothing():
    session = skin.Session.from_config(CONFIG)
    for f in log_frames()[:5]:
        assert session.push_can(f) == []
    with pytest.warns(skin.SkinWarning, match=r"finish\(\): the input ended after 5 frame\(s\), before the 20 complete untouched frames the baseline needs"):
        assert session.finish() == []
    # Ended: it takes no more frames, and finishing again says nothing.
    assert session.finish() == []
    with pytest.raises(skin.SessionError, match="has ended"):
        session.push_can(log_frames()[5])
    # A whole log that short is still an error, as it is for `skin run`.


def test_taxels_on_no_bus_are_warned_of_and_listed(tmp_path):
    layout = skin.read_layout(FIXTURES / "forearm" / "layout.json")
    busmap = skin.BusMap.read(FIXTURES / "forearm" / "busmap.toml")
    assert skin.Session.from_layout(layout, busmap=busmap).uncovered == []
    # The bus map without its last module: that module's taxels are on no bus.
    text = (FIXTURES / "forearm" / "busmap.toml").read_text()
    cut = text.rindex("[[")
    short = tmp_path / "busmap.toml"
    short.write_text(text[:cut])
    partial = skin.BusMap.read(short)
    lost = sorted(set(busmap.ids.tolist()) - set(partial.ids.tolist()))
    assert lost
    with pytest.warns(skin.SkinWarning, match=rf"{len(lost)} layout taxel\(s\) are on no bus of the bus map \(first: taxel \d+ of link \"forearm\"\)"):
        session = skin.Session.from_layout(layout, busmap=partial)
    assert sorted(id for link, id in session.uncovered) == lost
    assert {link for link, _ in session.uncovered} == {"forearm"}


def test_defaults_agree_between_run_toml_python_keywords_and_the_library(tmp_path):
    """One set of defaults: a run.toml that sets nothing, Session.from_layout with no keyword
    and read_session_settings() give the same settings, every option (the Rust tests hold the
    library's own defaults to the same run.toml)."""
    layout_path = FIXTURES / "forearm" / "layout.json"
    config = tmp_path / "run.toml"
    config.write_text(f'layout = "{layout_path.as_posix()}"\n')
    from_file = skin.Session.from_config(config).settings
    from_keywords = skin.Session.from_layout(skin.read_layout(layout_path)).settings
    defaults = skin.read_session_settings()
    assert from_file == from_keywords == defaults == skin.read_session_settings(config)
    # Every option is there, with run.toml's documented defaults.
    assert defaults["image_size"] == "68x100"
    assert defaults["baseline"] == {"frames": 20, "polarity": "rising"}
    touch = defaults["touch"]
    assert (touch["threshold"], touch["min_taxels"], touch["decide_frames"], touch["release_frames"]) == (
        5.0,
        2,
        3,
        2,
    )
    assert touch["contacts"] == "peaks" and defaults["gate"] is None
    # The peaks rule's parameters are shown as the session runs them, not left out.
    assert touch["split"] == {"min_dip": 0.5, "min_distance_mm": 12.0}


def test_keywords_set_what_run_toml_sets(tmp_path):
    layout_path = FIXTURES / "forearm" / "layout.json"
    config = tmp_path / "run.toml"
    config.write_text(
        f'layout = "{layout_path.as_posix()}"\nimage_size = "34x50"\n'
        '[baseline]\nframes = 30\npolarity = "falling"\n'
        "[touch]\nthreshold = 7.5\nmin_taxels = 3\ndecide_frames = 4\nrelease_frames = 5\n"
        '[gate]\nhand = "comply"\nnon_hand = "stop"\n'
    )
    from_keywords = skin.Session.from_layout(
        skin.read_layout(layout_path),
        image_size=(34, 50),
        baseline_frames=30,
        polarity="falling",
        threshold=7.5,
        min_taxels=3,
        decide_frames=4,
        release_frames=5,
        gate={"hand": "comply", "non_hand": "stop"},
    ).settings
    assert from_keywords == skin.Session.from_config(config).settings == skin.read_session_settings(config)


@pytest.mark.parametrize(
    "keyword, value, words",
    [
        ("threshold", -1.0, "threshold"),
        ("baseline_frames", 1, "baseline_frames"),
        ("polarity", "up", "rising"),
        ("gate", {"hand": "hug"}, "comply"),
        ("gate", {"hnad": "stop"}, "none of the classes"),
    ],
)
def test_a_keyword_out_of_run_tomls_bounds_is_named(keyword, value, words):
    layout = skin.read_layout(FIXTURES / "forearm" / "layout.json")
    with pytest.raises(skin.SkinError, match=words):
        skin.Session.from_layout(layout, **{keyword: value})


def test_a_force_calibration_gives_contacts_newtons_and_the_link_a_wrench(tmp_path):
    import pickle
    import re

    # The fixture's run.toml names the forearm's calibration (fixtures/forearm/force.md); the
    # same configuration without its [force] table is in counts.
    text = CONFIG.read_text().replace('"../', f'"{FIXTURES.as_posix()}/').replace('truth = "session.tsv"', f'truth = "{(FIXTURES / "session" / "session.tsv").as_posix()}"')
    config = tmp_path / "run.toml"
    config.write_text(re.sub(r"^\[force\][^\[]*", "", text, flags=re.M))
    assert "[force]" in text and "[force]" not in config.read_text()
    plain = skin.Session.from_config(config)
    session = skin.Session.from_config(CONFIG)
    assert session.wrench("forearm") is not None and plain.wrench("forearm") is None
    appeared = None
    for f in log_frames():
        plain.push_can(f)
        appeared = next((e for e in session.push_can(f) if e.kind == "appeared"), None)
        if appeared:
            break
    assert appeared is not None and appeared.force_n > 0
    contacts = session.contacts(0)
    assert all(c.force_n is not None and c.force_n > 0 for c in contacts)
    assert all(c.force_n is None for c in plain.contacts(0))
    assert abs(sum(c.force_n for c in contacts) - appeared.force_n) < 1e-5
    force, torque, cop = session.wrench(0)
    assert force.shape == torque.shape == cop.shape == (3,) and force.dtype == np.float64
    # The load on the link is the contacts' force, along the inward normals: its size is at most
    # their sum, and the torque about the origin is r x F of a force applied near the cop.
    assert 0 < np.linalg.norm(force) <= appeared.force_n + 1e-9
    np.testing.assert_allclose(torque, np.cross(cop, force), rtol=0.1, atol=1e-3)
    assert pickle.loads(pickle.dumps(contacts[0])) == contacts[0] and "N)" in repr(contacts[0])
    with pytest.raises(skin.ArrayError, match="link"):
        session.wrench("elbow")


def test_tare_relearns_the_baseline_and_is_refused_during_a_touch():
    layout = skin.read_layout(FIXTURES / "forearm" / "layout.json")
    session = skin.Session.from_layout(layout, baseline_frames=5, threshold=10.0)
    n = session.taxels[0]
    rest = np.full(n, 300.0, dtype=np.float32)
    pressed = rest.copy()
    pressed[100:112] += 40.0
    t = 0.0
    for _ in range(10):
        assert session.push([rest], t) == []
        t += 0.05
    # The rest level moved under a dozen taxels: a touch that stays. Tare refuses it, forced
    # it releases it, and the baseline is learned at the new rest level.
    kinds = []
    for _ in range(5):
        kinds += [e.kind for e in session.push([pressed], t)]
        t += 0.05
    assert kinds == ["appeared"]
    with pytest.raises(skin.SessionError, match="touch"):
        session.tare()
    assert "5 frames" in session.tare(force=True)
    events = session.push([pressed], t)
    assert [e.kind for e in events] == ["released", "tare"]
    assert events[1].to_dict()["forced"] is True
    for _ in range(8):
        t += 0.05
        assert session.push([pressed], t) == []
    pressed_more = pressed.copy()
    pressed_more[200:212] += 30.0
    appeared = []
    for _ in range(3):
        t += 0.05
        appeared += [e for e in session.push([pressed_more], t) if e.kind == "appeared"]
    assert len(appeared) == 1
    assert appeared[0].to_dict()["mean_pressure"] == pytest.approx(30.0, abs=1.0)


def test_describe_gives_the_layout_units_and_calibration():
    d = skin.Session.from_config(CONFIG).describe()
    layout = skin.read_layout(FIXTURES / "forearm" / "layout.json")
    (link,) = d["links"]
    assert d["simulated"] is False and d["touch_threshold_counts"] == 5.0
    assert link["units"] == "N" and link["calibration_id"].startswith("force.json#forearm sha256:")
    assert link["positions"].shape == (len(link["ids"]), 3)
    assert (link["ids"] == layout["forearm"].ids).all()
    assert link["areas"].sum() > 0.0 and (link["modules"] == link["ids"] >> 4).all()


def test_joint_states_need_a_urdf_and_a_position_per_joint():
    session = skin.Session.from_config(CONFIG)
    with pytest.raises(skin.ConfigError, match=r"\[stitch\] urdf"):
        session.joint_states(0.0, ["elbow"], [0.1])
    with pytest.raises(ValueError, match="2 positions for 1 joint names"):
        session.joint_states(0.0, ["elbow"], [0.1, 0.2])
