#!/usr/bin/env bash
# The whole test suite: the workspace's tests with every optional part built, then the Python
# package's (python/tests), against the package built into a venv of its own and the `skin`
# command the first step built, then the live view's in a real browser (skin-view/tests/browser:
# headless Chromium from the distribution's packages, driven by Selenium). Needs a Rust toolchain
# and Python 3.9 or later (with venv; 3.11 or later for skin.sim's MuJoCo tests); pip fetches
# maturin, pytest, onnxruntime, MuJoCo, Ray, HF datasets, pyarrow, selenium and pillow from the package registry. Without /usr/bin/chromium and /usr/bin/chromedriver
# (apt-get install chromium chromium-driver) the browser tests skip, saying so, unless
# SKIN_REQUIRE_BROWSER is set (CI sets it).
set -euo pipefail
cd "$(dirname "$0")/.."

cargo test --workspace --all-features

# The package as a user installs it (pip, through maturin), but built with the test build's
# settings (`dev` at opt-level 2) and its dependencies' features (the package's feature
# `test-build`), so it reuses what `cargo test` compiled instead of building every dependency a
# second time (tools/check-shared-build.py checks that it does).
venv=target/py-venv
if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv"
fi
"$venv/bin/python" -m pip install --quiet --disable-pip-version-check -r python/tests/requirements.txt
CARGO_PROFILE_DEV_OPT_LEVEL=2 MATURIN_PEP517_ARGS="--profile dev --features test-build" \
    "$venv/bin/python" -m pip install --quiet --disable-pip-version-check ./python
# pytest exits 5 when it collects nothing: that fails this script (set -e) as any failure does.
# The report (target/pytest.xml, written anew) lets .ci/run check what ran.
rm -f target/pytest.xml
SKIN="$PWD/target/debug/skin" "$venv/bin/python" -m pytest -q python/tests --junitxml=target/pytest.xml

"$venv/bin/python" -m pip install --quiet --disable-pip-version-check -r skin-view/tests/browser/requirements.txt
rm -f target/browser.xml
SKIN="$PWD/target/debug/skin" SKIN_VIEW_SCREENSHOT="$PWD/target/view-screenshot.png" \
    "$venv/bin/python" -m pytest -q -rs skin-view/tests/browser --junitxml=target/browser.xml
