"""onnxruntime on the MATLAB-exported HandsNet of ../shared/data, for comparison with
`cargo bench -p skin-learn --features onnx --bench classify` in the same run: batch-1 latency on
one and two threads (the model's input is fixed at batch 1).

    pip install onnxruntime numpy
    python3 bench/classify_onnxruntime.py
"""

import json
import os
import timeit

import numpy as np
import onnxruntime as ort

here = os.path.dirname(__file__)
model = os.path.join(here, "..", "..", "shared", "data", "cyskin", "HandsNet_handles_finetuned.onnx")
r, c = np.mgrid[0:68, 0:100]
image = np.where(np.hypot(r - 34.0, c - 50.0) < 18.0, 200.0, 0.0).astype(np.float32)[None, None]
ort.set_default_logger_severity(3)  # the MATLAB export lists its weights as inputs: ort warns
out = {"onnxruntime": ort.__version__}
for threads in [1, 2]:
    opts = ort.SessionOptions()
    opts.intra_op_num_threads = threads
    opts.inter_op_num_threads = 1
    sess = ort.InferenceSession(model, opts, providers=["CPUExecutionProvider"])
    name = sess.get_inputs()[0].name
    sess.run(None, {name: image})
    runs = 300
    best = min(timeit.repeat(lambda: sess.run(None, {name: image}), number=runs, repeat=5)) / runs
    out[f"batch1_{threads}t_ms"] = best * 1e3
    print(f"onnxruntime {ort.__version__}, batch 1, {threads} thread(s): {best * 1e3:.2f} ms")
folder = os.path.join(here, "..", "target", "bench-data")
os.makedirs(folder, exist_ok=True)
json.dump(out, open(os.path.join(folder, "onnxruntime_handsnet.json"), "w"), indent=1)
