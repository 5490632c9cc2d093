"""Frame-to-paint latency of the live view, measured in the browser: the full arm (3,495 taxels,
three links) at 50 frames/s (`examples/full_arm_live.rs`) to one headless Chromium, the page's
own record of each frame's time from the session handing it over to the end of its drawing.

    cargo build --release -p skin-view --example full_arm_live
    target/py-venv/bin/python skin-view/bench/latency.py   # selenium from skin-view/tests/browser

Prints p50 / p95 / p99 / max latency, the frames the page drew per second, and the frames it
skipped, over 20 s after a 5 s warm-up (the script does not touch the page meanwhile: polling
it through WebDriver competes with its drawing)."""

import re
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "browser"))
from conftest import CHROMEDRIVER, CHROMIUM  # noqa: E402

REPO = Path(__file__).resolve().parents[2]
EXAMPLE = REPO / "target" / "release" / "examples" / "full_arm_live"
WARM, MEASURE, RATE = 5.0, 20.0, 50


def main() -> None:
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    server = subprocess.Popen([str(EXAMPLE), "0", str(WARM + MEASURE + 10), str(RATE)], stderr=subprocess.PIPE, text=True)
    url = None
    for line in server.stderr:
        m = re.search(r"http://[0-9.:]+/", line)
        if m:
            url = m.group(0)
            break
    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for flag in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync",
                 "--disable-dev-shm-usage", "--force-device-scale-factor=1", "--window-size=1600,1400"):
        options.add_argument(flag)
    driver = webdriver.Chrome(service=Service(executable_path=CHROMEDRIVER), options=options)
    try:
        driver.get(url)
        time.sleep(WARM)
        driver.execute_script("const V = window.skinView; V.latencies = []; V.mark = [V.frames, V.frame ? V.frame.skipped : 0, performance.now()];")
        time.sleep(MEASURE)
        r = driver.execute_script(
            "const V = window.skinView; return {lat: V.latencies, frames: V.frames - V.mark[0],"
            " skipped: V.frame.skipped - V.mark[1], ms: performance.now() - V.mark[2], taxels: V.frame.pressures.length}"
        )
    finally:
        driver.quit()
        server.kill()
    lat = sorted(r["lat"])
    q = lambda p: lat[min(len(lat) - 1, int(p * len(lat)))]  # noqa: E731
    print(f"full arm: {r['taxels']} taxels at {RATE} frames/s, {MEASURE:.0f} s, one headless Chromium")
    print(f"frames received {r['frames']} ({r['frames'] / r['ms'] * 1e3:.1f}/s), drawn {len(lat)} ({len(lat) / r['ms'] * 1e3:.1f}/s), skipped by the server {r['skipped']}")
    print(f"frame to paint, ms: p50 {q(0.5):.1f}  p95 {q(0.95):.1f}  p99 {q(0.99):.1f}  max {lat[-1]:.1f}")


if __name__ == "__main__":
    main()
