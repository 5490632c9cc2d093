"""Bad input of every kind: the right exception, the argument or file named, no crash, no panic,
nothing written."""

import os

import numpy as np
import pytest

import skin
from conftest import FIXTURES

LAYOUT = FIXTURES / "forearm" / "layout.json"
CONFIG = FIXTURES / "session" / "run.toml"


@pytest.fixture(scope="module")
def tmap():
    return skin.read_map(LAYOUT)


@pytest.fixture(scope="module")
def imager(tmap):
    return skin.Imager(tmap)


def test_the_exceptions_form_one_family():
    for cls in (skin.InputError, skin.ConfigError, skin.ModelError, skin.ArrayError, skin.GeometryError, skin.SessionError, skin.ControlError):
        assert issubclass(cls, skin.SkinError)
    assert issubclass(skin.ArrayError, ValueError)


def test_missing_and_foreign_files_are_named(tmp_path):
    with pytest.raises(skin.InputError, match="nope.json"):
        skin.read_layout(tmp_path / "nope.json")
    binary = tmp_path / "layout.json"
    binary.write_bytes(b"\x00\x01\x02" * 100)
    with pytest.raises(skin.InputError, match="layout.json"):
        skin.read_layout(binary)
    with pytest.raises(skin.InputError, match="nope.txt"):
        skin.read_recording(tmp_path / "nope.txt")
    with pytest.raises(skin.InputError, match="nope.toml"):
        skin.BusMap.read(tmp_path / "nope.toml")
    with pytest.raises(skin.InputError, match="no.log"):
        skin.read_log(tmp_path / "no.log", skin.BusMap.read(FIXTURES / "forearm" / "busmap.toml"), skin.read_layout(LAYOUT))
    with pytest.raises(skin.InputError, match="a NUL byte"):
        skin.Session.from_config(CONFIG).run_log("/dev/zero")


def test_a_missing_file_is_a_file_not_found_error_and_an_input_error(tmp_path):
    busmap = skin.BusMap.read(FIXTURES / "forearm" / "busmap.toml")
    reads = [
        lambda: skin.read_layout(tmp_path / "nope.json"),
        lambda: skin.read_map(tmp_path / "nope.json"),
        lambda: skin.read_recording(tmp_path / "nope.txt"),
        lambda: skin.BusMap.read(tmp_path / "nope.toml"),
        lambda: skin.read_log(tmp_path / "nope.log", busmap, skin.read_layout(LAYOUT)),
        lambda: skin.Session.from_config(tmp_path / "nope.toml"),
        lambda: skin.read_session_settings(tmp_path / "nope.toml"),
        lambda: skin.read_probes(tmp_path / "nope.csv"),
    ]
    for read in reads:
        with pytest.raises(FileNotFoundError, match="nope") as caught:
            read()
        assert isinstance(caught.value, skin.InputError) and isinstance(caught.value, skin.MissingFileError)
    # A file that is there but wrong stays an InputError only.
    bad = tmp_path / "layout.json"
    bad.write_text("{")
    with pytest.raises(skin.InputError) as caught:
        skin.read_layout(bad)
    assert not isinstance(caught.value, FileNotFoundError)


def test_a_bad_configuration_is_a_config_error(tmp_path):
    cfg = tmp_path / "run.toml"
    cfg.write_text('layout = "../forearm/layout.json"\n[touch]\nthreshold = "high"\n')
    with pytest.raises(skin.ConfigError, match="run.toml"):
        skin.Session.from_config(cfg)
    cfg.write_text(f'layout = "{LAYOUT}"\nclassifier = "{cfg}"\n')
    with pytest.raises(skin.ModelError, match="run.toml"):
        skin.Session.from_config(cfg)


def test_arrays_of_the_wrong_kind_are_named(imager, tmap):
    n = len(tmap)
    with pytest.raises(skin.ArrayError, match="frame: dtype <U1"):
        imager.image(np.array(["a"] * n))
    with pytest.raises(skin.ArrayError, match="frame: dtype complex128"):
        imager.image(np.zeros(n, dtype=complex))
    with pytest.raises(skin.ArrayError, match="frame: 2 dimensions"):
        imager.image(np.zeros((2, n)))
    with pytest.raises(skin.ArrayError, match=f"frame: shape \\({n - 1},\\): {n - 1} readings a frame, the map has {n} taxels"):
        imager.image(np.zeros(n - 1))
    bad = np.zeros(n)
    bad[7] = np.nan
    with pytest.raises(skin.ArrayError, match=r"frame: NaN at index \[7\]"):
        imager.image(bad)
    with pytest.raises(skin.ArrayError, match=r"frames: inf at index \[1, 3\]"):
        f = np.zeros((2, n))
        f[1, 3] = np.inf
        imager.images(f)
    with pytest.raises(skin.ArrayError, match="frames"):
        imager.images(object())


def test_what_numpy_can_convert_is_accepted(imager, tmap):
    rng = np.random.default_rng(0)
    frames = rng.uniform(0, 50, size=(6, len(tmap))).astype(np.float32)
    expected = imager.images(frames)
    np.testing.assert_array_equal(imager.images(frames.astype(np.float64)), expected)
    np.testing.assert_array_equal(imager.images(frames.tolist()), expected)
    strided = np.asfortranarray(frames)
    np.testing.assert_array_equal(imager.images(strided), expected)
    np.testing.assert_array_equal(imager.images(np.repeat(frames, 2, axis=0)[::2]), expected)
    np.testing.assert_array_equal(imager.images(np.zeros((0, len(tmap)))), np.zeros((0, *imager.size), np.uint8))
    np.testing.assert_array_equal(imager.image(np.round(frames[0]).astype(np.int32)), imager.image(np.round(frames[0])))


def test_bad_options_are_named(tmap):
    for kwargs, name in [
        ({"step_mm": 0.0}, "step_mm"),
        ({"grid": (0, 10)}, "grid"),
        ({"size": (5000, 10)}, "size"),
        ({"norm": "loud"}, "norm"),
        ({"norm": "full_scale"}, "full_scale"),
        ({"norm": "full_scale", "full_scale": -1}, "full_scale"),
        ({"threshold": float("nan")}, "threshold"),
    ]:
        with pytest.raises(skin.ArrayError, match=name):
            skin.Imager(tmap, **kwargs)
    link = skin.read_layout(LAYOUT)[0]
    with pytest.raises(skin.ArrayError, match="max_edge"):
        skin.flatten(link, max_edge=-1)


def test_conversions_that_would_change_values_are_refused(imager, tmap):
    with pytest.raises(skin.ArrayError, match="ids: 1.5 is not a whole number"):
        skin.Link("l", [1.5], [[0, 0, 0]], [[0, 0, 1]])
    with pytest.raises(skin.ArrayError, match="ids: nan is not a whole number"):
        skin.Link("l", [float("nan")], [[0, 0, 0]], [[0, 0, 1]])
    with pytest.raises(skin.ArrayError, match="frame: 1e308 is beyond float32's range"):
        imager.image(np.full(len(tmap), 1e308))
    assert skin.Link("l", [3.0], [[0, 0, 0]], [[0, 0, 1]]).ids.tolist() == [3]


def test_bad_links_are_named():
    p = np.zeros((3, 3))
    p[:, 0] = [0, 0.01, 0.02]
    n = np.tile([0.0, 0.0, 1.0], (3, 1))
    with pytest.raises(skin.ArrayError, match="ids: 4 appears twice"):
        skin.Link("l", [4, 5, 4], p, n)
    with pytest.raises(skin.ArrayError, match="ids: -1 at index 0"):
        skin.Link("l", [-1, 5, 6], p, n)
    with pytest.raises(skin.ArrayError, match=r"positions: shape \(2, 3\), expected \(3, 3\)"):
        skin.Link("l", [1, 2, 3], p[:2], n)
    zero = n.copy()
    zero[1] = 0
    with pytest.raises(skin.ArrayError, match=r"normals: row 1 \(taxel 2\) is zero"):
        skin.Link("l", [1, 2, 3], p, zero)
    with pytest.raises(skin.ArrayError, match="faces: row 0: index 3"):
        skin.Link("l", [1, 2, 3], p, n, faces=[[0, 1, 3]])
    with pytest.raises(skin.GeometryError, match='link "l"'):
        skin.flatten(skin.Link("l", [1, 2, 3], p, n))


def test_bad_frames_for_the_session_are_named():
    session = skin.Session.from_config(CONFIG)
    ok = np.zeros(715, dtype=np.float32)
    with pytest.raises(skin.ArrayError, match="readings: 2 arrays, the skin has 1 links"):
        session.push([ok, ok], 0.0)
    with pytest.raises(skin.ArrayError, match=r"readings\[\"forearm\"\]: 714 readings, the link has 715 taxels"):
        session.push([ok[:-1]], 0.0)
    with pytest.raises(skin.ArrayError, match='no readings for link "forearm"'):
        session.push({"elbow": ok}, 0.0)
    bad = ok.copy()
    bad[9] = np.nan
    with pytest.raises(skin.ArrayError, match=r"readings\[\"forearm\"\]: NaN at index \[9\]"):
        session.push([bad], 0.0)
    with pytest.raises(skin.ArrayError, match="time: -1"):
        session.push([ok], -1.0)
    with pytest.raises(skin.ArrayError, match="readings"):
        session.push(42, 0.0)
    with pytest.raises(skin.ArrayError, match="classifier: not callable"):
        skin.Session.from_config(CONFIG, classifier="handsnet")
    # After all that, the session still runs.
    assert session.push([ok], 0.0) == []
    assert session.stats["frames"] == 1


def test_nothing_is_written_on_failure(tmp_path, tmap):
    before = sorted(os.listdir(tmp_path))
    with pytest.raises(skin.ArrayError):
        tmap.write(tmp_path / "m.json", format="svg")
    assert sorted(os.listdir(tmp_path)) == before
    (tmp_path / "folder").mkdir()
    with pytest.raises(skin.InputError, match="folder"):
        tmap.write(tmp_path / "folder")
    assert os.listdir(tmp_path / "folder") == []


GARBAGE = [None, 0, -1, 1e308, float("nan"), "", "x", b"\xff", [], [[]], {}, object(), np.zeros(0), np.zeros((0, 0)), np.zeros((3, 0)), np.array([np.inf]), np.zeros(10**6, dtype=np.int8)]


def test_garbage_arguments_never_panic(tmap, imager, tmp_path):
    """Every function, every argument slot, arbitrary values: a Python exception, never a Rust
    panic (pyo3's PanicException derives from BaseException, not Exception)."""
    session = skin.Session.from_layout(skin.read_layout(LAYOUT))
    stack = skin.TaskStack(3)
    calls = [
        lambda g: skin.read_layout(g),
        lambda g: skin.read_map(g),
        lambda g: skin.read_recording(g),
        lambda g: skin.flatten(g),
        lambda g: skin.Link("l", g, g, g),
        lambda g: skin.Link("l", [1], g, [[0, 0, 1]]),
        lambda g: skin.Imager(g),
        lambda g: skin.Imager(tmap, step_mm=g),
        lambda g: skin.Imager(tmap, size=g),
        lambda g: imager.image(g),
        lambda g: imager.images(g),
        lambda g: imager.images(np.zeros((1, len(tmap))), out=g),
        lambda g: imager.pressure_image(g),
        lambda g: session.push(g, 0.0),
        lambda g: session.push([np.zeros(715)], g),
        lambda g: session.contacts(g),
        lambda g: session.run_log(g),
        lambda g: skin.calibrate(g, g, g),
        lambda g: skin.calibrate(np.zeros((2, 3)), [1, 2], g),
        lambda g: skin.synthesize(tmap, g),
        lambda g: skin.read_grey(g),
        lambda g: stack.solve(g),
        lambda g: stack.solve([(g, g, 1.0)]),
        lambda g: skin.TaskStack(g),
        lambda g: skin.Session.from_layout(g),
        lambda g: skin.Session.from_config(g),
    ]
    cwd = os.getcwd()
    os.chdir(tmp_path)
    try:
        for k, call in enumerate(calls):
            for g in GARBAGE:
                try:
                    call(g)
                except Exception:
                    pass
                except BaseException as e:  # a PanicException
                    pytest.fail(f"call {k} with {g!r:.40}: {type(e).__name__}: {e}")
    finally:
        os.chdir(cwd)
    assert os.listdir(tmp_path) == []


def log_frames(layout_path=LAYOUT):
    layout = skin.read_layout(layout_path)
    return list(skin.read_log(FIXTURES / "session" / "session.candump.log", skin.BusMap.read(FIXTURES / "forearm" / "busmap.toml"), layout))


def test_frames_come_in_time_order_and_not_after_the_end():
    frames = log_frames()
    session = skin.Session.from_config(CONFIG)
    session.push_can(frames[1])
    with pytest.raises(skin.ArrayError, match=r"frame: .* is before the previous frame's"):
        session.push_can(frames[0])
    with pytest.raises(skin.ArrayError, match=r"time: 0.000000 s is before the previous frame's"):
        session.push([frames[2].values[0]], 0.0)
    for f in frames[2:30]:
        session.push_can(f)
    session.finish()
    assert session.finish() == []
    with pytest.raises(skin.SessionError, match=r"ended \(finish\(\)\)"):
        session.push_can(frames[30])
    with pytest.raises(skin.SessionError, match="run_log"):
        session.run_log(FIXTURES / "session" / "session.candump.log")
    whole = skin.Session.from_config(CONFIG)
    whole.run_log(FIXTURES / "session" / "session.candump.log")
    with pytest.raises(skin.SessionError, match=r"ended \(run_log\(\)\): run_log\(\) takes a new Session"):
        whole.run_log(FIXTURES / "session" / "session.candump.log")


def test_a_frame_of_another_bus_map_or_none_is_named():
    arm = skin.read_layout(FIXTURES / "arm" / "layout.json")
    arm_frames = skin.read_log(FIXTURES / "arm" / "touch.candump.log", skin.BusMap.read(FIXTURES / "arm" / "busmap.toml"), arm)
    session = skin.Session.from_config(CONFIG)
    with pytest.raises(skin.ArrayError, match="frame: a frame of 990 slots, this session's bus map has 715"):
        session.push_can(next(arm_frames))
    with pytest.raises(skin.SessionError, match="busmap="):
        skin.Session.from_layout(skin.read_layout(LAYOUT)).run_log(FIXTURES / "session" / "session.candump.log")


def test_taxels_on_no_bus_are_listed():
    arm = skin.read_layout(FIXTURES / "arm" / "layout.json")
    frames = skin.read_log(FIXTURES / "session" / "session.candump.log", skin.BusMap.read(FIXTURES / "forearm" / "busmap.toml"), arm)
    wrist = [i for link, i in frames.uncovered if link == "wrist"]
    assert len(wrist) == len(arm["wrist"])
    f = next(frames)
    assert f.complete and np.isnan(f.values[1]).all()


def test_a_classifier_must_give_probabilities():
    session = skin.Session.from_config(CONFIG, classifier=lambda image: np.array([-3.0, 2.0]))
    with pytest.raises(skin.ModelError, match="softmax"):
        session.run_log(FIXTURES / "session" / "session.candump.log")
    session = skin.Session.from_config(CONFIG, classifier=lambda image: None)
    with pytest.raises(skin.ModelError, match="returned None"):
        session.run_log(FIXTURES / "session" / "session.candump.log")
    session = skin.Session.from_config(CONFIG, classifier=lambda image: [0.2, 0.3, 0.5])
    with pytest.raises(skin.ModelError, match=r"frame at 1.150 s, link forearm, touch 0: .*3 class scores"):
        session.run_log(FIXTURES / "session" / "session.candump.log")
    with pytest.raises(skin.ArrayError, match='hand: "nope" is none of the classes'):
        skin.Session.from_config(CONFIG, classifier=lambda image: [1.0, 0.0], hand="nope")


def test_whole_numbers_are_named_and_sequences_accepted(tmap):
    for call, name in [
        (lambda: skin.Imager(tmap, size=(-5, 10)), "size"),
        (lambda: skin.Imager(tmap, size=(68,)), "size"),
        (lambda: skin.Imager(tmap, grid=(1.5, 3)), "grid"),
        (lambda: skin.synthesize(tmap, -1), "count"),
        (lambda: skin.synthesize(tmap, 3, seed=-1), "seed"),
        (lambda: skin.synthesize(tmap, 3, subjects=0), "subjects"),
        (lambda: skin.synthesize(tmap, 3, blind_spots=-2), "blind_spots"),
        (lambda: skin.synthesize(tmap, 3, blind_spots=0), "blind_spots"),
        (lambda: skin.synthesize(tmap, 3, blind_spots=2, blind_radius_mm=0.0), "blind_radius_mm"),
        (lambda: skin.synthesize(tmap, 3, remove_up_to=1.0), "remove_up_to"),
        (lambda: skin.synthesize(tmap, 3, remove_up_to=float("nan")), "remove_up_to"),
        (lambda: skin.synthesize(tmap, 3, remove_up_to=0.5, thinned_share=1.5), "thinned_share"),
        (lambda: skin.synthesize(tmap, 3, remove_up_to=0.5, blind_spots=2, blind_share=0.6), "blind_share"),
        (lambda: skin.synthesize(tmap, 3, mask_labels="drawn"), "mask_labels"),
        (lambda: skin.TaskStack(-1), "joints"),
        (lambda: skin.Session.from_layout(skin.read_layout(LAYOUT), baseline_frames=-1), "baseline_frames"),
        (lambda: skin.Session.from_layout(skin.read_layout(LAYOUT), baseline_frames=0), "baseline_frames"),
        (lambda: skin.Session.from_layout(skin.read_layout(LAYOUT), image_size="big"), "image_size"),
    ]:
        with pytest.raises(skin.ArrayError, match=f"^{name}: "):
            call()
    assert skin.Imager(tmap, size=[68, 100]).size == skin.Imager(tmap, size=np.array([68, 100])).size == (68, 100)


def test_options_that_contradict_are_refused(tmap):
    with pytest.raises(skin.ArrayError, match="full_scale: only with norm"):
        skin.Imager(tmap, full_scale=100.0)
    with pytest.raises(skin.ArrayError, match="grid: give grid or step_mm"):
        skin.Imager(tmap, grid=(10, 10), step_mm=2.0)
    # A share or radius without the degradation it belongs to would be ignored: refused instead.
    for kwargs, message in [
        ({"thinned_share": 0.4}, "^thinned_share: only with remove_up_to"),
        ({"thinned_share": 0.4, "blind_spots": 2}, "^thinned_share: only with remove_up_to"),
        ({"blind_share": 0.2}, "^blind_share: only with blind_spots"),
        ({"blind_radius_mm": 10.0, "remove_up_to": 0.5}, "^blind_radius_mm: only with blind_spots"),
    ]:
        with pytest.raises(skin.ArrayError, match=message):
            skin.synthesize(tmap, 3, **kwargs)
    probes = skin.read_probes(FIXTURES / "hex_patch" / "probes.csv")
    for kwargs, name in [({"outward": (0, 0, 0)}, "outward"), ({"outward": (np.nan, 0, 1)}, "outward"), ({"max_iterations": 0}, "max_iterations"), ({"max_open_angle_deg": 400}, "max_open_angle_deg")]:
        with pytest.raises(skin.ArrayError, match=name):
            skin.calibrate(probes["centroids"], probes["ids"], probes["responses"], **kwargs)


def test_a_map_of_a_layout_of_several_links_names_its_link():
    arm = FIXTURES / "arm" / "layout.json"
    with pytest.raises(skin.ArrayError, match=r"link: .*2 links \(forearm, wrist\); choose one with link="):
        skin.read_map(arm)
    wrist = skin.read_map(arm, link="wrist")
    np.testing.assert_array_equal(wrist.uv, skin.flatten(skin.read_layout(arm)["wrist"]).uv)
    with pytest.raises(skin.ArrayError, match='no link "elbow"'):
        skin.read_map(arm, link="elbow")
    with pytest.raises(IndexError):
        skin.read_layout(arm)[5]


def test_one_imager_in_two_threads_says_so(tmap):
    import threading

    imager = skin.Imager(tmap)
    big = np.tile(np.ones(len(tmap), dtype=np.float32), (20000, 1))
    errors = []
    worker = threading.Thread(target=lambda: imager.images(big))
    worker.start()
    # Poll while the other thread images (about a second): the imager says it is in use.
    while worker.is_alive() and not errors:
        try:
            imager.image(big[0])
        except skin.SkinError as e:
            errors.append(str(e))
    worker.join()
    assert errors and "the imager is in use (by another thread" in errors[0]
    # Free again once the other thread is done.
    assert imager.image(big[0]).shape == imager.size


def test_a_failed_start_leaves_the_session_usable(tmp_path):
    session = skin.Session.from_config(CONFIG)
    with pytest.raises(skin.InputError, match="nope.log"):
        session.run_log(tmp_path / "nope.log")
    assert len([e for e in session.run_log(FIXTURES / "session" / "session.candump.log") if e.kind == "released"]) == 20


def test_names_of_scores_without_a_python_classifier_are_refused():
    with pytest.raises(skin.ArrayError, match="classes: names the scores of a Python classifier"):
        skin.Session.from_config(CONFIG, classes=["a", "b"])
    with pytest.raises(skin.ArrayError, match="hand: names the scores"):
        skin.Session.from_layout(skin.read_layout(LAYOUT), hand="hand")


def test_a_segmenter_answer_that_is_not_labels_is_named():
    session = skin.Session.from_config(CONFIG, segmenter=lambda image: np.full(image.shape, 2.5))
    with pytest.raises(skin.ArrayError, match="segmenter's answer: 2.5 is not a whole number"):
        session.run_log(FIXTURES / "session" / "session.candump.log")
    session = skin.Session.from_config(CONFIG, segmenter=lambda image: np.zeros(10, dtype=np.uint8))
    with pytest.raises(skin.ModelError, match=r"frame at 1.150 s, link forearm, touch 0: .*10 labels"):
        session.run_log(FIXTURES / "session" / "session.candump.log")


def test_a_map_file_is_not_another_link(tmp_path):
    path = tmp_path / "forearm.json"
    skin.read_map(LAYOUT).write(path)
    assert skin.read_map(path, link="forearm").name == "forearm"
    with pytest.raises(skin.ArrayError, match='a map of link "forearm", not "wrist"'):
        skin.read_map(path, link="wrist")


def test_outward_is_any_sequence():
    probes = skin.read_probes(FIXTURES / "hex_patch" / "probes.csv")
    a = skin.calibrate(probes["centroids"], probes["ids"], probes["responses"], outward=[0, 0, 1])
    b = skin.calibrate(probes["centroids"], probes["ids"], probes["responses"], outward=np.array([0.0, 0.0, 1.0]))
    np.testing.assert_array_equal(a.normals, b.normals)
    with pytest.raises(skin.ArrayError, match="outward: 2 values"):
        skin.calibrate(probes["centroids"], probes["ids"], probes["responses"], outward=[0, 1])


def test_messages_say_the_bounds_and_units():
    layout = skin.read_layout(LAYOUT)
    # Every way out of range names the range and what it counts, not "0 or more" for a -1.
    for given in (-1, 0, 1, 100_001, 10**30, 2.5):
        with pytest.raises(skin.ArrayError, match=r"^baseline_frames: .*expected a whole number from 2 to 100000 \(untouched frames"):
            skin.Session.from_layout(layout, baseline_frames=given)
    with pytest.raises(skin.ArrayError, match=r"^decide_frames: -3: expected a whole number from 1 to 1000000"):
        skin.Session.from_layout(layout, decide_frames=-3)
    with pytest.raises(skin.ArrayError, match=r"^threshold: -1: expected counts from 0 to 1e9"):
        skin.Session.from_layout(layout, threshold=-1.0)
    with pytest.raises(skin.ArrayError, match=r"^max_edge: -1: .*in taxel pitches .*not mm or m"):
        skin.flatten(layout[0], max_edge=-1)
    session = skin.Session.from_config(CONFIG)
    ok = np.zeros(715, dtype=np.float32)
    # A 301-digit time: the number in exponent form and the range allowed.
    for huge in (10**300, 1e300):
        with pytest.raises(skin.ArrayError, match=r"^time: 1e300: expected seconds from 0 to 1.8e13") as e:
            session.push([ok], huge)
        assert len(str(e.value)) < 200
    with pytest.raises(skin.ArrayError, match=r"^time: -1: expected seconds from 0 to 1.8e13"):
        session.push([ok], -1.0)
    with pytest.raises(skin.ArrayError, match=r"^step_mm: 1e300: expected 0.01 to 1000 mm"):
        skin.Imager(skin.read_map(LAYOUT), step_mm=1e300)


def test_class_names_given_twice_are_refused():
    with pytest.raises(skin.ArrayError, match=r'^classes: class "hand" names outputs 0 and 2: each output needs a name of its own'):
        skin.Session.from_config(CONFIG, classifier=lambda image: [0.5, 0.2, 0.3], classes=["hand", "object", "hand"])


def test_ctrl_c_inside_numpy_conversion_is_not_a_bad_argument(imager):
    # An exception that is no Exception (KeyboardInterrupt) while an argument is converted
    # reaches the caller as itself, not as an ArrayError that `except ValueError` would swallow.
    class Interrupting:
        def __array__(self, *args, **kwargs):
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        imager.image(Interrupting())

    class Broken:
        def __array__(self, *args, **kwargs):
            raise RuntimeError("no")

    with pytest.raises(skin.ArrayError, match="frame: not an array of numbers"):
        imager.image(Broken())


def test_images_copy_the_frames_before_checking_them(tmap):
    # A thread writes NaN into rows not yet imaged while `images` runs without the GIL: each
    # image is of the frame as checked, or the NaN is named; never a NaN imaged as no pressure.
    import threading

    imager = skin.Imager(tmap, size=(68, 100))
    rng = np.random.default_rng(9)
    original = rng.uniform(0, 60, (3000, len(tmap))).astype(np.float32)
    expected = imager.images(original)
    for attempt in range(3):
        frames = original.copy()
        started = threading.Event()

        def spoil():
            started.set()
            for t in range(len(frames) - 1, 0, -7):
                frames[t, :] = np.nan

        writer = threading.Thread(target=spoil)
        writer.start()
        started.wait()
        try:
            got = imager.images(frames)
        except skin.ArrayError as e:
            assert "frames: nan at index" in str(e).lower()
        else:
            np.testing.assert_array_equal(got, expected)
        writer.join()


def test_every_error_skin_sim_raises_is_a_skin_error():
    """Read from the source, so that it holds without MuJoCo too: each `raise` in skin.sim names
    a SkinError class (ImportError only where MuJoCo or Python is missing, re-raises as they
    are)."""
    import ast
    from pathlib import Path

    sim = Path(skin.__file__).parent / "sim"
    allowed_outside = {"ImportError"}
    found = 0
    for path in sorted(sim.glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if not isinstance(node, ast.Raise) or node.exc is None:
                continue
            exc = node.exc.func if isinstance(node.exc, ast.Call) else node.exc
            name = exc.id if isinstance(exc, ast.Name) else getattr(exc, "attr", None)
            if name is None or name in allowed_outside or name[0].islower():
                continue  # a re-raise of a caught exception, or the missing-MuJoCo ImportError
            found += 1
            cls = getattr(skin, name, None)
            assert isinstance(cls, type) and issubclass(cls, skin.SkinError), f"{path.name}:{node.lineno}: raises {name}"
    assert found > 30, found
