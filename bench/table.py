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
