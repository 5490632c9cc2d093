"""Bring your own model: HandsNet run by onnxruntime (any Python callable would do: a PyTorch
module, a scikit-learn pipeline) as the session's classifier, frame by frame from a CAN log.

    pip install onnxruntime
    python python/examples/own_classifier.py      # from the repository root
"""

import numpy as np
import onnxruntime

import skin

net = onnxruntime.InferenceSession("fixtures/models/handsnet.onnx", providers=["CPUExecutionProvider"])


def classify(image: np.ndarray) -> np.ndarray:
    """(68, 100) uint8 tactile image -> [p(hand), p(non_hand)] (the model card: pixels / 255)."""
    x = image.astype(np.float32)[None, None] / 255.0
    return net.run(None, {"image": x})[0][0]


layout = skin.read_layout("fixtures/forearm/layout.json")
busmap = skin.BusMap.read("fixtures/forearm/busmap.toml")
# The configuration's segmenter still names the hand parts; the classifier is ours.
session = skin.Session.from_config("fixtures/session/run.toml", classifier=classify)
for frame in skin.read_log("fixtures/session/session.candump.log", busmap, layout):
    for event in session.push_can(frame):
        if event.kind == "classified":
            parts = ", ".join(p["part"] for p in event.parts)
            print(f"{event.time:6.2f} s  touch {event.touch}: {event['class']} {event.probability:.3f}  {parts}")
        elif event.kind == "gate":
            print(f"{event.time:6.2f} s  the robot should {event.action}")
for event in session.finish():
    print(f"end: touch {event.touch} released")
