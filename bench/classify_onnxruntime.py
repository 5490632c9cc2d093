"""onnxruntime on the tactile image models, for comparison with
`cargo bench -p skin-learn --features onnx --bench classify` in the same run: the
MATLAB-exported HandsNet of ../shared/data (input fixed at batch 1), and the project's HandsNet
and hand-part segmenters of fixtures/models (dynamic batch): batch-1 latency on one and two
threads, and batch-32 time per image.

    pip install onnxruntime numpy
    python3 bench/classify_onnxruntime.py
"""

import json
import os
import timeit

import numpy as np
import onnxruntime as ort

here = os.path.dirname(__file__)
models = {
    "handsnet": (os.path.join(here, "..", "..", "shared", "data", "cyskin", "HandsNet_handles_finetuned.onnx"), 1.0),
    "handsnet-ours": (os.path.join(here, "..", "fixtures", "models", "handsnet.onnx"), 1 / 255),
    "handseg": (os.path.join(here, "..", "fixtures", "models", "handseg.onnx"), 1 / 255),
    "handseg-wide": (os.path.join(here, "..", "fixtures", "models", "handseg_wide.onnx"), 1 / 255),
}
r, c = np.mgrid[0:68, 0:100]
blob = np.where(np.hypot(r - 34.0, c - 50.0) < 18.0, 200.0, 0.0).astype(np.float32)[None, None]
ort.set_default_logger_severity(3)  # the MATLAB export lists its weights as inputs: ort warns
out = {"onnxruntime": ort.__version__}
for name, (model, scale) in models.items():
    if not os.path.exists(model):
        print(f"skipped {name}: {model} not found")
        continue
    for threads in [1, 2]:
        opts = ort.SessionOptions()
        opts.intra_op_num_threads = threads
        opts.inter_op_num_threads = 1
        sess = ort.InferenceSession(model, opts, providers=["CPUExecutionProvider"])
        inp = sess.get_inputs()[0]
        batches = [1] if inp.shape[0] == 1 else [1, 32]
        for n in batches:
            x = np.repeat(blob * scale, n, axis=0).astype(np.float32)
            sess.run(None, {inp.name: x})
            runs = max(10, 300 // n)
            best = min(timeit.repeat(lambda: sess.run(None, {inp.name: x}), number=runs, repeat=5)) / runs
            out[f"{name}_batch{n}_{threads}t_ms"] = best * 1e3
            print(f"onnxruntime {ort.__version__}, {name}, batch {n}, {threads} thread(s): "
                  f"{best * 1e3:.2f} ms ({best * 1e3 / n:.2f} ms per image)")
folder = os.path.join(here, "..", "target", "bench-data")
os.makedirs(folder, exist_ok=True)
json.dump(out, open(os.path.join(folder, "onnxruntime_models.json"), "w"), indent=1)
