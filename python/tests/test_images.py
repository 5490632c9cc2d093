"""Tactile images: pixel-equal to `skin image`, batches, the pressure image, threads."""

import threading
import time

import numpy as np
import pytest

import skin
from conftest import FIXTURES, run_skin

LAYOUT = FIXTURES / "forearm" / "layout.json"
RECORDING = FIXTURES / "forearm" / "touches.txt"


@pytest.fixture(scope="module")
def tmap():
    return skin.flatten(skin.read_layout(LAYOUT)[0])


@pytest.fixture(scope="module")
def frames(tmap):
    return skin.read_recording(RECORDING).for_taxels(tmap.ids, threshold=3.0)


def cli_images(tmp_path, *options):
    out = tmp_path / "images"
    run_skin("image", "--map", LAYOUT, RECORDING, "-o", out, "-q", "--threshold", "3", *options)
    files = sorted((out / "touches").glob("frame_*.png"))
    assert len(files) == len(skin.read_recording(RECORDING))
    return np.stack([skin.read_grey(f) for f in files])


@pytest.mark.parametrize(
    "options, kwargs",
    [
        ((), {}),
        (("--morph", "--size", "68x100"), {"morph": True, "size": (68, 100)}),
        (("--step-mm", "2.5", "--norm", "full-scale", "--full-scale", "40"), {"step_mm": 2.5, "norm": "full_scale", "full_scale": 40}),
        (("--grid", "50x80"), {"grid": (50, 80)}),
    ],
)
def test_images_equal_skin_image(tmp_path, tmap, frames, options, kwargs):
    expected = cli_images(tmp_path, *options)
    imager = skin.Imager(tmap, **kwargs)
    got = imager.images(frames)
    assert got.dtype == np.uint8 and got.shape == expected.shape
    np.testing.assert_array_equal(got, expected)
    # Frame by frame, the same.
    for t in (0, len(frames) // 2, len(frames) - 1):
        np.testing.assert_array_equal(imager.image(frames[t]), expected[t])


def test_threshold_is_applied_as_the_command_does(tmap):
    rec = skin.read_recording(RECORDING)
    raw = rec.for_taxels(tmap.ids)
    a = skin.Imager(tmap, threshold=3.0).images(raw)
    b = skin.Imager(tmap).images(rec.for_taxels(tmap.ids, threshold=3.0))
    np.testing.assert_array_equal(a, b)


def test_images_into_a_given_array(tmap, frames):
    imager = skin.Imager(tmap, size=(68, 100))
    out = np.zeros((len(frames), 68, 100), dtype=np.uint8)
    assert imager.images(frames, out=out) is out
    np.testing.assert_array_equal(out, imager.images(frames))
    with pytest.raises(skin.ArrayError, match="out"):
        imager.images(frames, out=np.zeros((len(frames), 68, 99), dtype=np.uint8))
    ro = np.zeros((len(frames), 68, 100), dtype=np.uint8)
    ro.flags.writeable = False
    with pytest.raises(skin.ArrayError, match="out: read-only"):
        imager.images(frames, out=ro)
    with pytest.raises(skin.ArrayError, match="out"):
        imager.images(frames, out=np.zeros((len(frames), 68, 100), dtype=np.float32))


def test_pressure_image_interpolates_a_uniform_press(tmap):
    imager = skin.Imager(tmap)
    k = imager.pressure_image(np.full(len(tmap), 100.0, dtype=np.float32))
    assert k.dtype == np.float32 and k.ndim == 2
    inside = k[k > 0]
    # Barycentric interpolation of equal pressures is that pressure wherever the map is.
    np.testing.assert_allclose(inside, 100.0, rtol=1e-5)
    grey = imager.image(np.full(len(tmap), 100.0))
    # floor(255 K / max K): 255, or 254 where the weights sum to a hair under 1.
    assert set(np.unique(grey)) <= {0, 254, 255}


def test_two_threads_with_their_own_imagers_match_one(tmap, frames):
    big = np.tile(frames, (4, 1))
    one = skin.Imager(tmap).images(big)
    results = [None, None]

    def work(i):
        results[i] = skin.Imager(tmap).images(big)

    threads = [threading.Thread(target=work, args=(i,)) for i in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    np.testing.assert_array_equal(results[0], one)
    np.testing.assert_array_equal(results[1], one)


def test_the_gil_is_released_while_imaging(tmap, frames):
    big = np.tile(frames, (40, 1))
    imager = skin.Imager(tmap)
    started = time.perf_counter()
    imager.images(big[: len(frames)])
    per_batch = time.perf_counter() - started
    ticks = []
    done = threading.Event()

    def ticker():
        while not done.is_set():
            ticks.append(time.perf_counter())
            time.sleep(0.001)

    t = threading.Thread(target=ticker)
    t.start()
    time.sleep(0.01)
    before = len(ticks)
    imager.images(big)
    after = len(ticks)
    done.set()
    t.join()
    # The other thread kept ticking while this one imaged (with the GIL held it would not tick
    # at all until the call returned). The call takes about 40 batches' time.
    assert after - before >= min(5, int(40 * per_batch / 0.002)), f"{after - before} ticks while imaging {len(big)} frames"
