#!/usr/bin/env python3
"""Checks that the Python package's build shares every dependency with the workspace's test build.

tools/test-all.sh runs `cargo test --workspace --all-features`, then builds the Python package
(python/, through pip and maturin) with its feature `test-build` and the `dev` profile. Cargo
compiles a crate again whenever the features it is built with differ between two builds, and a
difference deep down (a proc macro's `syn`) rebuilds nearly everything above it: a third of a
cold CI run. This script asks cargo for the artifacts of both builds (compiling nothing the two
builds have not already compiled) and fails, naming the crate and both feature lists, when a crate
of the package's build is also in the test build but was compiled apart from it. The mend: add the
missing features to python/Cargo.toml's `test-build` dependencies.

Usage: tools/check-shared-build.py (from anywhere; exit 0 when everything shared is shared).
"""
import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def artifacts(args, env=None):
    """Cargo's compiled units of one build: (package id, target name) -> [(file, features)]."""
    run_env = dict(os.environ)
    run_env.update(env or {})
    run = subprocess.run(
        ["cargo", *args, "--message-format=json"],
        cwd=ROOT,
        env=run_env,
        stdout=subprocess.PIPE,
        text=True,
        check=False,
    )
    if run.returncode != 0:
        sys.exit(f"check-shared-build: `cargo {' '.join(args)}` failed (exit {run.returncode})")
    units = {}
    for line in run.stdout.splitlines():
        message = json.loads(line)
        if message.get("reason") != "compiler-artifact":
            continue
        key = (message["package_id"], message["target"]["name"])
        units.setdefault(key, []).append((Path(message["filenames"][0]).name, message["features"]))
    return units


def main():
    test_build = artifacts(["test", "--workspace", "--all-features", "--no-run"])
    # As tools/test-all.sh has maturin build it.
    package_build = artifacts(
        ["build", "-p", "skin-python", "--features", "test-build", "--profile", "dev"],
        {"CARGO_PROFILE_DEV_OPT_LEVEL": "2"},
    )
    shared, apart = 0, []
    for key, units in package_build.items():
        if key not in test_build:
            continue  # the package's own crates (pyo3, numpy, ...): nothing to share
        for file, features in units:
            if any(file == other for other, _ in test_build[key]):
                shared += 1
            else:
                apart.append((key, features, [f for _, f in test_build[key]]))
    for (package, target), features, others in apart:
        print(f"compiled twice: {package} ({target}): the package's build with features {features}, "
              f"the test build's with {others}")
    print(f"check-shared-build: {shared} units shared, {len(apart)} compiled twice")
    if apart:
        print("add the test build's features to python/Cargo.toml's `test-build` dependencies "
              "(for a proc macro's crates: its [build-dependencies])")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
