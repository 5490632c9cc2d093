"""Prints the BENCHMARKS.md rows from one run of bench/run.sh: criterion's medians for the Rust
side (target/criterion/*/new/estimates.json) next to the reference timings the Python scripts
wrote (target/bench-data/{libigl,numpy}.json), with the ratio."""

import glob
import json
import os

root = os.path.join(os.path.dirname(__file__), "..", "target")


def criterion(pattern: str) -> dict:
    out = {}
    for path in glob.glob(os.path.join(root, "criterion", pattern, "new", "estimates.json")):
        bench = json.load(open(os.path.join(os.path.dirname(path), "benchmark.json")))
        out[bench["full_id"]] = json.load(open(path))["median"]["point_estimate"] / 1e6  # ms
    return out


lscm = criterion("lscm/*/*")
igl = json.load(open(os.path.join(root, "bench-data", "libigl.json")))
print("| LSCM, vertices | skin (faer), full | skin, cached symbolic | libigl igl.lscm | libigl / skin |")
print("|---|---|---|---|---|")
for n in sorted(igl, key=int):
    full = lscm.get(f"lscm/full/{n}")
    cached = lscm.get(f"lscm/cached_symbolic/{n}")
    print(f"| {int(n):,} | {full:.2f} ms | {cached:.2f} ms | {igl[n]:.2f} ms | {igl[n] / full:.1f}x |")

image = criterion("image_*")
ref = json.load(open(os.path.join(root, "bench-data", "numpy.json")))
print()
print("| tactile image, one core | skin | numpy + scipy.sparse (+ OpenCV) | numpy / skin |")
print("|---|---|---|---|")
for name, ms in sorted(image.items()):
    size = name.split("taxels, ")[1].split(" px")[0].replace(" ", "")
    key = "with_morphology_us" if "erode" in name else "interpolate_quantise_us"
    theirs = ref[size][key]
    print(f"| {name.split('/', 1)[1]} | {ms * 1e3:.1f} us | {theirs:.1f} us | {theirs / (ms * 1e3):.1f}x |")

calib = criterion("calibrate/*")
scipy = json.load(open(os.path.join(root, "bench-data", "scipy_calibration.json")))
print()
print("| calibration | skin, 1 thread | skin, 2 threads | scipy curve_fit, 1 thread | scipy / skin (1 thread) | taxels fitted (skin / scipy) |")
print("|---|---|---|---|---|---|")
for key, name in [("hex", "61 taxels x 350 contacts"), ("arm_2000", "3500 taxels x 2000 contacts"), ("arm_20000", "3500 taxels x 20000 contacts")]:
    one = calib[f"calibrate/{name}/1 thread"]
    two = calib[f"calibrate/{name}/2 threads"]
    ours = open(os.path.join(root, "bench-data", f"calibration_{key}.fitted")).read().split()[0]
    theirs = scipy[key]
    print(f"| {name} | {one:.2f} ms | {two:.2f} ms | {theirs['ms']:.1f} ms | {theirs['ms'] / one:.0f}x | {ours} / {theirs['fitted']} |")
