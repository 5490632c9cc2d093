"""Tests of train.py's own algorithms, run by .ci/run where PyTorch is installed:

    python -m unittest discover -s skin-learn/training
"""

import os
import sys
import unittest

import numpy as np
import torch
import torch.nn.functional as F

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import train  # noqa: E402


def randomised(model):
    """A model whose batch-norm statistics and affine parts are not the identity, so that a
    widening that misplaced a channel would show."""
    with torch.no_grad():
        for m in model.modules():
            if isinstance(m, torch.nn.BatchNorm2d):
                m.running_mean.uniform_(-0.5, 0.5)
                m.running_var.uniform_(0.5, 2.0)
                m.weight.uniform_(0.5, 1.5)
                m.bias.uniform_(-0.2, 0.2)
    return model.eval()


class Widen(unittest.TestCase):
    def test_a_widened_segmenter_computes_what_the_narrow_one_did(self):
        torch.manual_seed(1)
        narrow = randomised(train.HandSeg(8))
        x = torch.rand(3, 1, 68, 100)
        with torch.no_grad():
            want = narrow(x)
        for width in (12, 16):
            wide = train.HandSeg(width)
            train.widen(narrow.state_dict(), wide)
            self.assertEqual(wide.conv1[0].weight.shape[0], width)
            with torch.no_grad():
                got = wide.eval()(x)
            self.assertLess(float((got - want).abs().max()), 1e-4 * float(want.abs().max()), width)

    def test_the_new_channels_learn(self):
        torch.manual_seed(2)
        wide = train.HandSeg(12)
        train.widen(randomised(train.HandSeg(8)).state_dict(), wide)
        wide.train()
        y = torch.randint(0, 7, (2, 68, 100))
        F.cross_entropy(wide(torch.rand(2, 1, 68, 100)), y).backward()
        # The head reads the new channels through weights that start at zero; they must move.
        self.assertGreater(float(wide.head.weight.grad[:, 8:].abs().sum()), 0.0)


class Lovasz(unittest.TestCase):
    def test_on_hard_predictions_it_is_one_minus_the_mean_iou_over_part_pixels(self):
        rng = np.random.default_rng(3)
        y = rng.integers(0, 7, size=(2, 20, 30))
        y[y == 5] = 0  # a part absent from the batch does not count
        pred = np.where(rng.random(y.shape) < 0.7, y, rng.integers(0, 7, size=y.shape))
        logits = F.one_hot(torch.from_numpy(pred), 7).permute(0, 3, 1, 2).double() * 1e3
        got = float(train.lovasz_softmax(logits, torch.from_numpy(y)))
        on = y > 0
        ious = []
        for c in range(1, 7):
            gt, pr = (y == c) & on, (pred == c) & on
            if gt.any():
                ious.append((gt & pr).sum() / (gt | pr).sum())
        self.assertEqual(len(ious), 5)
        self.assertAlmostEqual(got, 1 - float(np.mean(ious)), places=9)

    def test_it_is_zero_when_right_and_has_a_gradient_when_not(self):
        y = torch.randint(1, 7, (1, 10, 10))
        right = F.one_hot(y, 7).permute(0, 3, 1, 2).float() * 1e3
        self.assertAlmostEqual(float(train.lovasz_softmax(right, y)), 0.0, places=6)
        logits = torch.zeros(1, 7, 10, 10, requires_grad=True)
        train.lovasz_softmax(logits, y).backward()
        self.assertGreater(float(logits.grad.abs().sum()), 0.0)



class Lean(unittest.TestCase):
    def test_the_lean_export_is_four_convolutions_and_gives_what_torch_gives(self):
        import tempfile
        import types

        import onnx

        torch.manual_seed(4)
        model = randomised(train.LeanHandsNet())
        with tempfile.TemporaryDirectory() as d:
            a = types.SimpleNamespace(out=os.path.join(d, "lean.onnx"), dataset=["DIR"], seed=0, arch="lean")
            info = dict(arch="lean", train_images=1, test_images=1, subjects=1, test_subjects_from=1)
            train.export(model, a, 68, 100, False, {}, info)
            ops = [n.op_type for n in onnx.load(a.out).graph.node]
            self.assertEqual(ops.count("Conv"), 4)
            self.assertNotIn("BatchNormalization", ops)  # folded into the convolutions
            self.assertIn("HandsNet, lean", open(os.path.join(d, "lean.md")).read())
            try:
                import onnxruntime as ort
            except ImportError:
                return
            x = torch.rand(3, 1, 68, 100)
            with torch.no_grad():
                want = torch.softmax(model(x), 1).numpy()
            got = ort.InferenceSession(a.out, providers=["CPUExecutionProvider"]).run(None, {"image": x.numpy()})[0]
            self.assertLess(float(np.abs(got - want).max()), 1e-5)
        # A sixth of Table 4.1's multiply-adds, or less.
        def macs(m):
            total = 0
            def hook(mod, inp, out):
                nonlocal total
                total += out.numel() * mod.weight[0].numel()
            hs = [c.register_forward_hook(hook) for c in m.modules() if isinstance(c, (torch.nn.Conv2d, torch.nn.Linear))]
            with torch.no_grad():
                m.eval()(torch.zeros(1, 1, 68, 100))
            for h in hs:
                h.remove()
            return total
        self.assertLess(macs(model) * 6, macs(train.HandsNet()))


if __name__ == "__main__":
    unittest.main()

