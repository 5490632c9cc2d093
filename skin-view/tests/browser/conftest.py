"""Browser tests of the live view: the `skin` command serves the page (`skin run --view`,
`skin view`), the distribution's headless Chromium shows it, driven through ChromeDriver by
Selenium. Chromium and ChromeDriver come from Debian's packages (`apt-get install chromium
chromium-driver`; `.ci/run` installs them); without them every test here skips, saying so,
unless SKIN_REQUIRE_BROWSER is set (CI), where that is a failure."""

import json
import os
import re
import shutil
import signal
import subprocess
import time
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[3]
FIXTURES = REPO / "fixtures"
CHROMIUM = os.environ.get("SKIN_CHROMIUM", "/usr/bin/chromium")
CHROMEDRIVER = os.environ.get("SKIN_CHROMEDRIVER", "/usr/bin/chromedriver")
# The page's map canvases (index.html: MAP_W, MAP_H, PAD): a taxel at (u, v) mm is drawn at
# (PAD + (u - u0) * scale, PAD + (v1 - v) * scale), its link's extent fitted into the canvas.
MAP_W, MAP_H, PAD = 420, 360, 10


def skin_binary() -> Path:
    path = Path(os.environ.get("SKIN", REPO / "target" / "debug" / "skin"))
    if not path.is_file():
        pytest.fail(f"no `skin` command at {path}: build it (cargo build -p skin-cli) or set SKIN")
    return path


@pytest.fixture(scope="session")
def browser():
    missing = [p for p in (CHROMIUM, CHROMEDRIVER) if not shutil.which(p)]
    if missing:
        why = f"no {' or '.join(missing)}: apt-get install chromium chromium-driver"
        if os.environ.get("SKIN_REQUIRE_BROWSER"):
            pytest.fail(why)
        pytest.skip(why)
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    # The flags a closed network and a root user need (see the machine notes): no sandbox,
    # no background connections to Google's hosts.
    for flag in (
        "--headless=new",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--disable-dev-shm-usage",
        "--force-device-scale-factor=1",
        "--window-size=1600,1400",
    ):
        options.add_argument(flag)
    driver = webdriver.Chrome(service=Service(executable_path=CHROMEDRIVER), options=options)
    yield driver
    driver.quit()


class Served:
    """A `skin` command serving the page; stopped (Ctrl-C) at the end."""

    def __init__(self, *args):
        self.proc = subprocess.Popen(
            [str(skin_binary()), *map(str, args)],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        self.url = None
        self.said = []
        deadline = time.time() + 120
        while time.time() < deadline:
            line = self.proc.stderr.readline()
            if not line:
                break
            self.said.append(line)
            m = re.search(r"http://[0-9.:\[\]]+/", line)
            if m:
                self.url = m.group(0)
                return
        self.stop()
        pytest.fail(f"skin {' '.join(map(str, args))} served no page:\n{''.join(self.said)}")

    def stop(self):
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
            try:
                self.proc.wait(timeout=20)
            except subprocess.TimeoutExpired:
                self.proc.kill()
        rest = self.proc.stderr.read()
        return "".join(self.said) + rest


def wait_for(driver, script, timeout=60, what="the page"):
    """Polls `script` (JavaScript returning a value) until it is truthy; returns the value."""
    deadline = time.time() + timeout
    value = None
    while time.time() < deadline:
        value = driver.execute_script(script)
        if value:
            return value
        time.sleep(0.05)
    pytest.fail(f"timed out waiting for {what}: {script} gave {value!r}")


def transform(link: dict) -> dict:
    """Where the page draws a link's taxels: the fit of its map into the canvas, computed here
    from the scene (the map's uv and pitch) as index.html documents it."""
    us = [p[0] for p in link["uv_mm"]]
    vs = [p[1] for p in link["uv_mm"]]
    r = link["pitch_mm"] / 2
    u0, u1, v0, v1 = min(us) - r, max(us) + r, min(vs) - r, max(vs) + r
    scale = min((MAP_W - 2 * PAD) / (u1 - u0), (MAP_H - 2 * PAD) / (v1 - v0))
    return {"u0": u0, "v1": v1, "scale": scale, "w": int(-(-((u1 - u0) * scale + 2 * PAD) // 1)),
            "h": int(-(-((v1 - v0) * scale + 2 * PAD) // 1))}


def xy(t: dict, uv) -> tuple:
    return (PAD + (uv[0] - t["u0"]) * t["scale"], PAD + (t["v1"] - uv[1]) * t["scale"])
