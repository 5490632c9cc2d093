"""Where tract's and onnxruntime's times part: the lean HandsNet's four convolutions, each alone
with its own fixed input shape, and a bare matrix product of its last convolution's size, timed
by onnxruntime on one thread. Writes the models to target/bench-data/layers for tract:

    pip install onnx onnxruntime numpy
    python3 bench/conv_layers.py
    cargo bench -p skin-learn --features onnx --bench model_profile -- target/bench-data/layers/*.onnx
"""

import os
import timeit

import numpy as np
import onnx
import onnxruntime as ort
from onnx import TensorProto, helper, numpy_helper

here = os.path.dirname(os.path.abspath(__file__))
folder = os.path.join(here, "..", "target", "bench-data", "layers")
os.makedirs(folder, exist_ok=True)
rng = np.random.default_rng(0)


def conv(name, cin, cout, k, h, w):
    weights = numpy_helper.from_array(rng.standard_normal((cout, cin, k, k)).astype(np.float32) * 0.1, "w")
    bias = numpy_helper.from_array(np.zeros(cout, np.float32), "b")
    node = helper.make_node("Conv", ["x", "w", "b"], ["y"], kernel_shape=[k, k], pads=[k // 2] * 4)
    graph = helper.make_graph([node], name, [helper.make_tensor_value_info("x", TensorProto.FLOAT, [1, cin, h, w])],
                              [helper.make_tensor_value_info("y", TensorProto.FLOAT, [1, cout, h, w])], [weights, bias])
    return graph


def matmul(name, m, k, n):
    weights = numpy_helper.from_array(rng.standard_normal((k, n)).astype(np.float32) * 0.1, "w")
    node = helper.make_node("MatMul", ["x", "w"], ["y"])
    graph = helper.make_graph([node], name, [helper.make_tensor_value_info("x", TensorProto.FLOAT, [m, k])],
                              [helper.make_tensor_value_info("y", TensorProto.FLOAT, [m, n])], [weights])
    return graph


layers = {
    "conv1_5x5_1-16_68x100": conv("conv1", 1, 16, 5, 68, 100),
    "conv2_3x3_16-32_34x50": conv("conv2", 16, 32, 3, 34, 50),
    "conv3_3x3_32-64_17x25": conv("conv3", 32, 64, 3, 17, 25),
    "conv4_3x3_64-128_8x12": conv("conv4", 64, 128, 3, 8, 12),
    "matmul_96x576x128": matmul("matmul", 96, 576, 128),
}
for name, graph in layers.items():
    path = os.path.join(folder, name + ".onnx")
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    onnx.checker.check_model(model)
    onnx.save(model, path)
    opts = ort.SessionOptions()
    opts.intra_op_num_threads = 1
    opts.inter_op_num_threads = 1
    sess = ort.InferenceSession(path, opts, providers=["CPUExecutionProvider"])
    inp = sess.get_inputs()[0]
    x = rng.random(inp.shape).astype(np.float32)
    sess.run(None, {inp.name: x})
    best = min(timeit.repeat(lambda: sess.run(None, {inp.name: x}), number=300, repeat=7)) / 300
    print(f"onnxruntime {ort.__version__}, {name}, 1 thread: {best * 1e3:.3f} ms")
