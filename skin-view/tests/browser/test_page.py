"""The live view in a real browser: the fixture session served by `skin run --view`, a module
dropped from its log, and the MCAP replay of `skin view`, each checked on what the page shows:
screenshot pixels against the map's geometry, the timeline, the header."""

import io
import math
import os
import subprocess
import time
from pathlib import Path

import pytest
from conftest import FIXTURES, REPO, Served, skin_binary, transform, wait_for, xy
from PIL import Image
from selenium.webdriver.common.by import By

RUN = FIXTURES / "session" / "run.toml"
LOG = FIXTURES / "session" / "session.candump.log"
# The page's colour of a taxel below the threshold (index.html: IDLE).
IDLE = (0x3A, 0x45, 0x52)

# A link's pressed taxels in the frame the page shows now, and that frame's number and time.
SHOWN = """
const V = window.skinView;
if (!V.frame || !V.scene) return null;
const L = V.links[arguments[0]], f = V.frame, pressed = [];
for (let i = 0; i < L.n; i++) if (f.pressures[L.offset + i] > V.scene.threshold) pressed.push(i);
return {number: f.number, time: f.time, pressed: pressed, missing: f.missing, incomplete: f.incomplete};
"""


def while_running(driver, script, *args, timeout=120):
    """`script`'s value, read again and again until the run is over (the page's `ended`) or
    `timeout` seconds have passed: how many reads that makes depends on the machine, so a loop
    over them is bounded by the run, not by a count."""
    deadline = time.time() + timeout
    while time.time() < deadline and not driver.execute_script("return window.skinView.ended === true"):
        yield driver.execute_script(script, *args)
        time.sleep(0.005)


def canvas_image(driver, k: int) -> Image.Image:
    canvas = driver.find_elements(By.CSS_SELECTOR, "canvas.map")[k]
    return Image.open(io.BytesIO(canvas.screenshot_as_png)).convert("RGB")


def differs(a, b, by=40) -> bool:
    return sum(abs(x - y) for x, y in zip(a, b)) > by


def check_pixels(image: Image.Image, link: dict, pressed: set, near: set):
    """Pressed taxels are painted in the pressure colours where the map puts them; taxels far
    from any pressed one keep the idle colour."""
    t = transform(link)
    assert image.size == (t["w"], t["h"]), f"canvas {image.size}, map fitted to {(t['w'], t['h'])}"
    hot = cold = far = 0
    for i, uv in enumerate(link["uv_mm"]):
        x, y = xy(t, uv)
        px = image.getpixel((int(x), int(y)))
        if i in pressed:
            hot += differs(px, IDLE)
        elif i not in near and i not in link["dead"]:
            far += 1
            cold += not differs(px, IDLE, by=6)
    assert pressed and hot >= 0.9 * len(pressed), f"{hot} of {len(pressed)} pressed taxels painted"
    assert far and cold >= 0.98 * far, f"{far - cold} of {far} taxels far from the press are not idle"


def near_any(link: dict, taxels: set, within_pitches: float) -> set:
    """Taxels within `within_pitches` of any of `taxels` on the map (contact outlines and
    labels are drawn there)."""
    uv = link["uv_mm"]
    d2 = (within_pitches * link["pitch_mm"]) ** 2
    return {
        i
        for i, (u, v) in enumerate(uv)
        if any((u - uv[j][0]) ** 2 + (v - uv[j][1]) ** 2 <= d2 for j in taxels)
    }


def scene(driver) -> dict:
    """The scene once it has links (`skin run` serves the page before its session is built)."""
    script = "const s = window.skinView.scene; return s && s.links.length && s"
    return wait_for(driver, script, what="the scene")


def test_a_press_is_painted_where_the_map_puts_it_and_touch_0_is_a_hand(browser, tmp_path):
    served = Served("run", RUN, "--log", LOG, "-o", tmp_path / "out", "-q", "--view", "0", "--speed", "0.5")
    try:
        browser.get(served.url)
        link = scene(browser)["links"][0]
        assert len(link["uv_mm"]) == 715
        wait_for(browser, "return window.skinView.frames > 0", what="a frame")
        checked = False
        for before in while_running(browser, SHOWN, 0):
            if not before or len(before["pressed"]) < 10:
                continue
            image = canvas_image(browser, 0)
            after = browser.execute_script(SHOWN, 0)
            # The screenshot shows one of the frames between the two readings: a taxel pressed
            # in both is painted hot, one pressed in neither and far from both stays idle.
            if after["number"] - before["number"] > 4:
                continue
            both = set(before["pressed"]) & set(after["pressed"])
            either = set(before["pressed"]) | set(after["pressed"])
            if len(both) < 10:
                continue
            check_pixels(image, link, both, near_any(link, either, 6))
            checked = True
            if os.environ.get("SKIN_VIEW_SCREENSHOT"):
                browser.save_screenshot(os.environ["SKIN_VIEW_SCREENSHOT"])
            break
        assert checked, "no press was seen on the page"
        row = '#touches tr[data-touch="0"] .class'
        # Its row appears with the touch, its class with the decision.
        decided = f"const e = document.querySelector('{row} span'); return e && e.textContent"
        cls = wait_for(browser, decided, what="touch 0's decision")
        assert cls == "hand"
        # A hand decided: the gate says comply (run.toml's [gate] hand = "comply").
        wait_for(browser, "return document.getElementById('gate').textContent === 'comply'", what="the gate")
        # The contacts drawn are the session's: centroid among the pressed taxels on the map.
        contact = wait_for(
            browser,
            "const f = window.skinView.frame; return f && f.contacts.length && {c: f.contacts[0], pressed: "
            "Array.from(f.pressures).map((p, i) => [p, i]).filter(([p]) => p > window.skinView.scene.threshold).map(([, i]) => i)}",
            what="a contact",
        )
        uv = [link["uv_mm"][i] for i in contact["pressed"]]
        c = contact["c"]
        assert min(u for u, _ in uv) <= c["u"] <= max(u for u, _ in uv)
        assert min(v for _, v in uv) <= c["v"] <= max(v for _, v in uv)
        assert 0 < c["taxels"] <= len(uv) and c["peak"] >= c["mean"] > 0
    finally:
        said = served.stop()
    assert "view the skin at" in said


def drop_module(src: Path, dst: Path, address: int, cycles: range) -> None:
    """Copies a skin16 log without module `address`'s data frames in the sync `cycles`."""
    ids = {f"{0x200 + 4 * address + k:03X}" for k in range(3)}
    syncs = -1
    with open(src) as f, open(dst, "w") as out:
        for line in f:
            can_id = line.split()[2].split("#")[0]
            if can_id == "080":
                syncs += 1
            if syncs in cycles and can_id in ids:
                continue
            out.write(line)


def test_a_module_dropped_from_the_log_shows_as_missing(browser, tmp_path):
    log = tmp_path / "dropped.log"
    drop_module(LOG, log, address=5, cycles=range(40, 400))
    served = Served("run", RUN, "--log", log, "-o", tmp_path / "out", "-q", "--view", "0", "--speed", "4")
    try:
        browser.get(served.url)
        sc = scene(browser)
        module = next(k for k, m in enumerate(sc["modules"]) if m["bus"] == "can0" and m["address"] == 5)
        wait_for(
            browser,
            "return document.getElementById('missing').textContent.includes('can0:5')",
            what="can0:5 among the missing modules",
        )
        # The frame says which module: its index among the scene's modules, and its taxels are
        # the ones ringed on the map.
        wait_for(browser, f"const f = window.skinView.frame; return f && f.missing.includes({module}) && f.incomplete > 0",
                 what=f"module {module} missing from a frame")
        # Once the log is over, the page says so (and keeps the last frame).
        wait_for(browser, "return document.getElementById('state').textContent.startsWith('run over')", what="the run's end")
    finally:
        served.stop()


def test_the_mcap_replay_seeks_to_a_time_and_shows_that_frame(browser, tmp_path):
    mcap = tmp_path / "session.mcap"
    done = subprocess.run(
        [str(skin_binary()), "run", str(RUN), "--log", str(LOG), "-o", str(tmp_path / "out"), "-q", "--mcap", str(mcap)],
        capture_output=True,
        text=True,
    )
    assert done.returncode == 0, done.stderr
    served = Served("view", mcap, "--view", "0")
    try:
        browser.get(served.url)
        sc = scene(browser)
        assert sc["replay"]["duration"] > 30
        # The timeline holds the whole run at once.
        cls = wait_for(
            browser,
            "const e = document.querySelector('#touches tr[data-touch=\"0\"] .class'); return e && e.textContent",
            what="touch 0 on the timeline",
        )
        assert cls == "hand"
        browser.execute_script("window.skinView.send({cmd: 'pause'})")
        # Touch 2 (a hand pushing away) presses from 4.0 s to 5.0 s.
        browser.execute_script("window.skinView.send({cmd: 'seek', time: 4.5})")
        shown = wait_for(
            browser,
            "const f = window.skinView.frame; return f && Math.abs(f.time - 4.5) < 0.06 && f.time",
            what="the frame at 4.5 s",
        )
        # Paused: the frame stays, so the screenshot shows exactly it.
        state = browser.execute_script(SHOWN, 0)
        image = canvas_image(browser, 0)
        again = browser.execute_script(SHOWN, 0)
        assert again["number"] == state["number"], "the paused replay moved on"
        link = sc["links"][0]
        pressed = set(state["pressed"])
        assert len(pressed) >= 10, f"{len(pressed)} taxels pressed at {shown} s"
        check_pixels(image, link, pressed, near_any(link, pressed, 6))
        # Past the end: the last frame, paused; play starts again from the beginning.
        browser.execute_script("window.skinView.send({cmd: 'play'}); window.skinView.send({cmd: 'seek', time: 1e6})")
        wait_for(browser, "return window.skinView.paused && window.skinView.frame.time > 30", what="the end, paused")
        browser.execute_script("window.skinView.send({cmd: 'play'})")
        wait_for(browser, "return !window.skinView.paused && window.skinView.frame.time < 5", what="playing from the start")
        browser.execute_script("window.skinView.send({cmd: 'pause'})")
        wait_for(browser, "return window.skinView.paused", what="paused again")
        # Seeking back shows the earlier frame (touch 1, a bar, 2.5 s to 3.5 s).
        browser.execute_script("window.skinView.send({cmd: 'seek', time: 2.75})")
        wait_for(browser, "const f = window.skinView.frame; return f && Math.abs(f.time - 2.75) < 0.06", what="2.75 s")
    finally:
        served.stop()


def test_a_damaged_mcap_is_said_on_the_page_and_a_bad_seek_is_refused(browser, tmp_path):
    mcap = tmp_path / "session.mcap"
    done = subprocess.run(
        [str(skin_binary()), "run", str(RUN), "--log", str(LOG), "-o", str(tmp_path / "out"), "-q", "--mcap", str(mcap)],
        capture_output=True,
        text=True,
    )
    assert done.returncode == 0, done.stderr
    data = bytearray(mcap.read_bytes())
    # Bytes flipped in the middle of the file: the chunks there fail their CRC.
    mid = len(data) // 2
    for k in range(50):
        data[mid - 25_000 + k * 1000] ^= 0x10
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(bytes(data))
    # Slowly (a frame every 2 s): the page shows the first frame long before the next.
    served = Served("view", bad, "--view", "0", "--speed", "0.01")
    try:
        browser.get(served.url)
        sc = scene(browser)
        damaged = sc["replay"]["damaged"]
        assert damaged and all(not d["left_out"] for d in damaged), damaged
        banner = wait_for(browser, "const e = document.getElementById('damage'); return e.classList.contains('on') && e.textContent",
                          what="the damage banner")
        assert "damaged" in banner and "cannot be trusted" in banner, banner
        assert f"{damaged[0]['from']:.2f} s" in banner, banner
        # The first frame drawn: no latency measured yet, and none shown (not "NaN").
        wait_for(browser, "return window.skinView.frames > 0", what="a frame")
        latency = browser.find_element(By.ID, "latency").text
        assert latency == "–", latency
        # A frame inside a damaged stretch is marked as such.
        browser.execute_script("window.skinView.send({cmd: 'pause'})")
        inside = (damaged[0]["from"] + damaged[0]["to"]) / 2
        browser.execute_script(f"window.skinView.send({{cmd: 'seek', time: {inside}}})")
        wait_for(browser, f"const f = window.skinView.frame; return f && Math.abs(f.time - {inside}) < 0.06", what="the damaged frame")
        wait_for(browser, "return document.getElementById('untrusted').classList.contains('on')", what="the frame marked untrusted")
        # The controls are shared, and the page says so; this page paused it, so no one else did.
        assert browser.find_element(By.ID, "shared").is_displayed()
        state = wait_for(browser, "const t = document.getElementById('state').textContent; return t.startsWith('replay, paused') && t",
                         what="paused")
        assert "another viewer" not in state, state
        # A seek to -1 s is refused with a message; the stream goes on.
        browser.execute_script("window.skinView.send({cmd: 'seek', time: -1})")
        notice = wait_for(browser, "return window.skinView.refused.length && document.getElementById('notice').textContent",
                          what="the refusal")
        assert "seek" in notice and "-1" in notice, notice
        assert browser.execute_script("return window.skinView.ws.readyState") == 1
        browser.execute_script("window.skinView.send({cmd: 'seek', time: 2.75})")
        wait_for(browser, "const f = window.skinView.frame; return f && Math.abs(f.time - 2.75) < 0.06", what="2.75 s after the refusal")
    finally:
        said = served.stop()
    assert "chunks are damaged" in said, said


ST_W, ST_H = 860, 360  # index.html: the stitched arm's canvas

# Every link's pressed taxels and the placements of the frame the page shows now.
STITCHED = """
const V = window.skinView, f = V.frame;
if (!f || !V.scene || !f.placements.length) return null;
const pressed = V.links.map((L) => { const out = []; for (let i = 0; i < L.n; i++) if (f.pressures[L.offset + i] > V.scene.threshold) out.push(i); return out; });
return {number: f.number, placements: f.placements, pressed: pressed};
"""


def placed(p: dict, uv) -> tuple:
    c, s = math.cos(p["angle"]), math.sin(p["angle"])
    return (c * uv[0] - s * uv[1] + p["du"], s * uv[0] + c * uv[1] + p["dv"])


def test_a_stitched_arm_is_drawn_at_the_current_posture(browser, tmp_path):
    served = Served("run", FIXTURES / "arm" / "run.toml", "--log", FIXTURES / "arm" / "touch.candump.log",
                    "-o", tmp_path / "out", "-q", "--view", "0", "--speed", "0.5", "--frames")
    try:
        browser.get(served.url)
        sc = scene(browser)
        assert sc["stitched"] and len(sc["links"]) == 2
        checked = False
        for before in while_running(browser, STITCHED):
            if not before or sum(map(len, before["pressed"])) < 10 or not all(before["pressed"]):
                continue
            canvas = browser.find_element(By.CSS_SELECTOR, "canvas.stitched")
            image = Image.open(io.BytesIO(canvas.screenshot_as_png)).convert("RGB")
            after = browser.execute_script(STITCHED)
            if after["number"] - before["number"] > 2 or after["placements"] != before["placements"]:
                continue
            # The fit of the placed links into the canvas, as index.html documents it.
            pl = before["placements"]
            pts = [[placed(pl[k], uv) for uv in link["uv_mm"]] for k, link in enumerate(sc["links"])]
            half = min(link["pitch_mm"] for link in sc["links"]) / 2
            us = [p[0] for ps in pts for p in ps]
            vs = [p[1] for ps in pts for p in ps]
            u0, u1, v0, v1 = min(us) - half, max(us) + half, min(vs) - half, max(vs) + half
            scale = min((ST_W - 2 * 10) / (u1 - u0), (ST_H - 2 * 10) / (v1 - v0))
            hot = total = 0
            for k, ps in enumerate(pts):
                both = set(before["pressed"][k]) & set(after["pressed"][k])
                for i in both:
                    x, y = 10 + (ps[i][0] - u0) * scale, 10 + (v1 - ps[i][1]) * scale
                    total += 1
                    hot += differs(image.getpixel((int(x), int(y))), IDLE)
            if total < 10:
                continue
            assert hot >= 0.9 * total, f"{hot} of {total} pressed taxels painted on the stitched arm"
            # The press crosses the joint: both links are pressed in the stitched view.
            checked = True
            break
        assert checked, "no press across the joint was seen on the stitched arm"
        # With --frames, each link's tactile image and the stitched arm's are shown beside it.
        wait_for(browser, "return document.querySelectorAll('.imgbox.on').length >= 3", what="three tactile images")
    finally:
        served.stop()


def test_a_port_in_use_is_one_clear_line_before_any_work(tmp_path):
    """No browser needed: `skin run --view PORT` on a taken port says so in one line, before
    the session is built, and writes nothing."""
    import socket

    taken = socket.socket()
    taken.bind(("127.0.0.1", 0))
    taken.listen(1)
    port = taken.getsockname()[1]
    try:
        done = subprocess.run(
            [str(skin_binary()), "run", str(RUN), "--log", str(LOG), "-o", str(tmp_path / "out"), "--view", str(port)],
            capture_output=True,
            text=True,
            timeout=120,
        )
    finally:
        taken.close()
    assert done.returncode != 0
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1, done.stderr
    assert f"127.0.0.1:{port}" in lines[0] and "in use" in lines[0], lines[0]
    assert not (tmp_path / "out").exists()
    # A mistyped address is refused by the argument parser, before anything is read.
    bad = subprocess.run([str(skin_binary()), "run", str(RUN), "--log", str(LOG), "-o", str(tmp_path / "o"), "--view", "80800"],
                         capture_output=True, text=True)
    assert bad.returncode == 2 and "--view" in bad.stderr
