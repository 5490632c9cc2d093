"""Newtons on the simulated rig: the fixture forearm calibrated by `skin.calibrate_force` from
scripted presses (`skin.sim.ForceRig`), then read by a session on presses it has not seen.

    python python/bench/sim_force.py [CALIBRATION_PRESSES] [HELD_OUT_PRESSES]     # 60 30

1. Calibrate on ball, bar and plate presses of 1 to 30 N at half of the skin's places (taxels).
2. Held out: presses of 2 to 20 N of each tool at the other half; per tool and over all, the
   median and 95th percentile of |read - load| / load over the frames whose load lies within 2
   and 20 N (ramps included), and the same for `ideal`, what a model that knew each taxel's
   stress would read (the floor any per-taxel model meets on this skin; `RigRun`).
3. Calibrated with one tool, read with the others (ball -> bar, plate; bar -> ball, plate; ...).
4. A 0.1 kg plate laid on the skin at ten places (its weight, 0.981 N, held 2 s).
5. Centre of pressure against MuJoCo's contact centre, across the skin (`RigReading.cop_error`),
   and the wrench's torque against centre x force.

Files go to a temporary folder; the fixture's configuration is read, not changed.
"""

from __future__ import annotations

import re
import sys
import tempfile
from pathlib import Path

import numpy as np

import skin
from skin.sim import ForceRig, RigPress, read_with, weight

ROOT = Path(__file__).resolve().parents[2]
CONFIG = ROOT / "fixtures" / "session" / "run.toml"


def configured(dir: Path, calibration: Path) -> Path:
    """The fixture's run.toml with `calibration` as its [force] (paths made absolute)."""
    text = CONFIG.read_text()
    text = re.sub(r'^(layout|busmap|classifier|segmenter|truth|cache) = "([^"]+)"', lambda m: f'{m[1]} = "{(CONFIG.parent / m[2]).resolve()}"', text, flags=re.M)
    text = re.sub(r"^\[force\][^\[]*", "", text, flags=re.M)
    path = dir / f"run-{calibration.stem}.toml"
    path.write_text(text + f'\n[force]\ncalibration = "{calibration}"\n')
    return path


def figures(err: np.ndarray) -> str:
    if len(err) == 0:
        return "   (no frame)"
    return f"{100 * np.median(err):5.1f}% {100 * np.percentile(err, 95):6.1f}%  ({len(err)} frames)"


def calibrate(rig: ForceRig, dir: Path, name: str, presses) -> Path:
    rec, load, out = dir / f"{name}.txt", dir / f"{name}.csv", dir / f"{name}.json"
    rig.record(presses, rec, load)
    fit = skin.calibrate_force(CONFIG, load, recording=rec, output=out)
    curve = fit["curve"]
    print(
        f"calibrated on {name}: {len(presses)} presses, R² {fit['fit']['r_squared']:.4f}, full scale "
        f"{curve['full_scale']:.0f} counts, half-scale stress {curve['half_scale_kpa']:.1f} kPa, "
        f"{fit['fit']['fitted_taxels']} taxels with gains of their own"
    )
    return configured(dir, out)


def held_out(rig: ForceRig, dir: Path, config: Path, name: str, presses):
    rec, load = dir / f"{name}.txt", dir / f"{name}.csv"
    run = rig.record(presses, rec, load)
    reading = read_with(skin.Session.from_config(config), rec, load)
    keep = (run.load >= 2.0) & (run.load <= 20.0)
    ideal = np.abs(run.ideal[keep] - run.load[keep]) / run.load[keep]
    return reading, ideal


def main(n_cal: int, n_held: int) -> None:
    rig = ForceRig(CONFIG)
    rng = np.random.default_rng(5)
    taxels = rng.permutation(len(rig.positions))
    cal_places, held_places = taxels[: len(taxels) // 2], taxels[len(taxels) // 2 :]
    tools = ("ball", "bar", "plate")
    with tempfile.TemporaryDirectory() as tmp:
        dir = Path(tmp)
        config = calibrate(rig, dir, "all", rig.script(n_cal, seed=1, places=cal_places))
        print(f"\nheld out (2-20 N), |read - load| / load:   median    p95          ideal: median    p95")
        every, every_ideal, readings = [], [], {}
        for k, tool in enumerate(tools):
            presses = rig.script(n_held // 3, seed=100 + k, tools=(tool,), forces=(2.0, 20.0), places=held_places)
            r, ideal = held_out(rig, dir, config, f"held-{tool}", presses)
            readings[tool] = r
            err = r.relative_error()
            every.append(err)
            every_ideal.append(ideal)
            print(f"  {tool:6s}  {figures(err)}      {figures(ideal)}")
        print(f"  {'all':6s}  {figures(np.concatenate(every))}      {figures(np.concatenate(every_ideal))}")

        print("\ncalibrated with one tool, read with another (2-20 N): median, p95")
        for k, tool in enumerate(tools):
            one = calibrate(rig, dir, f"only-{tool}", rig.script(n_cal // 2, seed=10 + k, tools=(tool,), places=cal_places))
            for other in tools:
                if other == tool:
                    continue
                presses = rig.script(n_held // 3, seed=200 + k, tools=(other,), forces=(2.0, 20.0), places=held_places)
                r, ideal = held_out(rig, dir, one, f"cross-{tool}-{other}", presses)
                print(f"  {tool:6s} -> {other:6s} {figures(r.relative_error())}      ideal {figures(ideal)}")

        print("\na 0.1 kg plate laid on the skin (0.981 N), held 2 s, at ten places:")
        places = rng.choice(np.intersect1d(rig.places("plate"), held_places), 10, replace=False)
        presses = [RigPress("plate", tuple(rig.positions[i]), tuple(rig.normals[i]), weight(0.1), 2.0) for i in places]
        rec, load = dir / "plate.txt", dir / "plate.csv"
        run = rig.record(presses, rec, load)
        r = read_with(skin.Session.from_config(config), rec, load)
        for start, end in run.spans:
            held = (r.times >= start + 0.5) & (r.times < end - 0.5)
            print(
                f"  {start:6.2f} s: MuJoCo {np.median(r.load[held]):.3f} N, read {np.median(r.force[held]):.3f} N "
                f"({100 * (np.median(r.force[held]) / 0.980665 - 1):+.1f}% of 0.981 N), ideal "
                f"{np.median(run.ideal[(run.times >= start + 0.5) & (run.times < end - 0.5)]):.3f} N"
            )

        print("\ncentre of pressure and torque (held-out presses, 2-20 N):")
        for tool, r in readings.items():
            keep = (r.load >= 2) & (r.load <= 20) & ~np.isnan(r.cop[:, 0]) & ~np.isnan(r.point[:, 0])
            d = 1e3 * r.cop_error()[keep]
            lever = np.cross(r.cop[keep], r.wrench[keep])
            t = np.linalg.norm(r.torque[keep] - lever, axis=1) / np.linalg.norm(r.torque[keep], axis=1)
            print(
                f"  {tool:6s} centre of pressure to MuJoCo's: median {np.median(d):.2f} mm, p95 {np.percentile(d, 95):.2f} mm; "
                f"|torque - cop x force| / |torque|: max {100 * t.max():.2f}%"
            )


if __name__ == "__main__":
    args = [int(a) for a in sys.argv[1:3]]
    main(*(args + [60, 30][len(args):]))
