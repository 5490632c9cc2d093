#!/usr/bin/env python3
"""Train HandsNet (hand / non-hand, thesis Table 4.1) or the hand-part segmenter on a dataset
written by `skin synth`, and export it to ONNX for skin-learn (tract) with a model card.

    python train.py handsnet --arch lean --dataset DIR --out fixtures/models/handsnet.onnx
    python train.py segnet   --dataset DIR --out fixtures/models/handseg.onnx

`--arch lean` trains the HandsNet the project ships: Table 4.1's four blocks over 16 to 128
channels instead of 32 to 256, a sixth of the multiply-adds, for the per-frame path.

Train and test are split by subject (the thesis' 70/30 split on unseen people). The defaults
are the thesis' recipe (App. C): HandsNet lr 0.01 x0.2 every 40 epochs, batch 64, 80 epochs,
cross-entropy, horizontal and vertical flips; the segmenter uses cross-entropy weighted by
median frequency balancing (App. C.2). Fine-tuning for a new link (Ch. 5.4): `--init OLD.pt
--first-convs-lr 0.1` starts from a trained model and trains its first two convolutions at a
tenth of the learning rate.

Everything is seeded; on the CPU the run is repeatable. Set OMP_WAIT_POLICY=PASSIVE on a busy
machine. `--smoke` runs one tiny epoch and checks the export (what CI runs when torch is there).
`--swa-from K` exports the average of the weights of epochs K to the last (stochastic weight
averaging), its batch-norm statistics recomputed on the training images. For the segmenter,
`--init NARROW.pt --width W` widens a trained model to W channels keeping its function, and
`--lovasz 1` adds an IoU surrogate to its loss. `python -m unittest discover -s
skin-learn/training` tests these.
"""

import argparse
import csv
import math
import os
import random
import sys
import time

import numpy as np
import torch
import torch.nn as nn
import torch.nn.functional as F
from PIL import Image

PARTS = ["background", "thumb", "index", "middle", "ring", "pinkie", "palm"]


class HandsNet(nn.Module):
    """Table 4.1: four conv(same)+BN+ReLU+maxpool blocks, then fc 64, 32, 2."""

    def __init__(self, rows=68, cols=100):
        super().__init__()

        def block(cin, cout, k):
            return nn.Sequential(
                nn.Conv2d(cin, cout, k, padding=k // 2),
                nn.BatchNorm2d(cout),
                nn.ReLU(inplace=True),
                nn.MaxPool2d(2, 2),
            )

        self.conv1 = block(1, 32, 7)
        self.drop1 = nn.Dropout(0.1)
        self.conv2 = block(32, 64, 5)
        self.drop2 = nn.Dropout(0.2)
        self.conv3 = block(64, 128, 3)
        self.conv4 = block(128, 256, 3)
        r, c = rows, cols
        for _ in range(4):
            r, c = r // 2, c // 2
        self.fc1 = nn.Linear(256 * r * c, 64)
        self.drop3 = nn.Dropout(0.6)
        self.fc2 = nn.Linear(64, 32)
        self.drop4 = nn.Dropout(0.5)
        self.fc3 = nn.Linear(32, 2)

    def forward(self, x):
        x = self.drop1(self.conv1(x))
        x = self.drop2(self.conv2(x))
        x = self.conv4(self.conv3(x))
        x = torch.flatten(x, 1)
        x = self.drop3(F.relu(self.fc1(x)))
        x = self.drop4(F.relu(self.fc2(x)))
        return self.fc3(x)

    def first_convs(self):
        return list(self.conv1.parameters()) + list(self.conv2.parameters())


class LeanHandsNet(nn.Module):
    """HandsNet with a fraction of the work, for the per-frame path: the same four blocks of
    convolution, batch norm, ReLU and 2 x 2 max-pool, and the same image size, but a 5 x 5 first
    convolution and 3 x 3 after it, over WIDTHS channels (16, 32, 64, 128: a sixth of Table
    4.1's multiply-adds), then one hidden layer of 64. The convolutions have no bias (batch
    norm follows, and the exporter folds it into them), so the exported model is four
    convolutions, four pools and two products."""

    def __init__(self, rows=68, cols=100, widths=(16, 32, 64, 128)):
        super().__init__()

        def block(cin, cout, k):
            return nn.Sequential(
                nn.Conv2d(cin, cout, k, padding=k // 2, bias=False),
                nn.BatchNorm2d(cout),
                nn.ReLU(inplace=True),
                nn.MaxPool2d(2, 2),
            )

        w = widths
        self.convs = nn.Sequential(block(1, w[0], 5), *[block(a, b, 3) for a, b in zip(w, w[1:])])
        r, c = rows, cols
        for _ in w:
            r, c = r // 2, c // 2
        self.fc1 = nn.Linear(w[-1] * r * c, 64)
        self.drop = nn.Dropout(0.5)
        self.fc2 = nn.Linear(64, 2)

    def forward(self, x):
        x = torch.flatten(self.convs(x), 1)
        return self.fc2(self.drop(F.relu(self.fc1(x))))

    def first_convs(self):
        return list(self.convs[0].parameters()) + list(self.convs[1].parameters())


class HandSeg(nn.Module):
    """A compact encoder-decoder with skip connections (a small U-Net): 68 x 100 in, 7 part
    scores per pixel out. Two 2x2 poolings, so the input sides must be multiples of 4. At the
    bottleneck, a residual block of dilated convolutions (dilation 2, 4, 8) lets every pixel
    see the whole hand: which finger is which depends on where the thumb and palm are, tens of
    pixels away, and the thesis' SegNet gets that reach from five poolings."""

    def __init__(self, width=16):
        super().__init__()

        def double(cin, cout):
            return nn.Sequential(
                nn.Conv2d(cin, cout, 3, padding=1),
                nn.BatchNorm2d(cout),
                nn.ReLU(inplace=True),
                nn.Conv2d(cout, cout, 3, padding=1),
                nn.BatchNorm2d(cout),
                nn.ReLU(inplace=True),
            )

        w = width
        self.conv1 = double(1, w)
        self.conv2 = double(w, 2 * w)
        self.conv3 = double(2 * w, 4 * w)
        self.context = nn.Sequential(*[
            nn.Sequential(nn.Conv2d(4 * w, 4 * w, 3, padding=d, dilation=d), nn.BatchNorm2d(4 * w), nn.ReLU(inplace=True))
            for d in (2, 4, 8)
        ])
        self.up2 = nn.ConvTranspose2d(4 * w, 2 * w, 2, stride=2)
        self.dec2 = double(4 * w, 2 * w)
        self.up1 = nn.ConvTranspose2d(2 * w, w, 2, stride=2)
        self.dec1 = double(2 * w, w)
        self.head = nn.Conv2d(w, len(PARTS), 1)

    def forward(self, x):
        e1 = self.conv1(x)
        e2 = self.conv2(F.max_pool2d(e1, 2))
        e3 = self.conv3(F.max_pool2d(e2, 2))
        e3 = e3 + self.context(e3)
        d2 = self.dec2(torch.cat([self.up2(e3), e2], 1))
        d1 = self.dec1(torch.cat([self.up1(d2), e1], 1))
        return self.head(d1)

    def first_convs(self):
        return list(self.conv1.parameters()) + list(self.conv2.parameters())


def widen(old, model):
    """Load the weights `old` of a narrower HandSeg into `model`, keeping its function (the
    zero-init expansion of Net2Net): each old channel keeps its place (within each half of the
    decoders' concatenated inputs) and weights; the new channels keep the model's random
    incoming weights, and every weight reading a new channel starts at zero, so the wider
    network computes what the narrow one did and the new channels learn from there."""
    new = model.state_dict()
    for name, t in new.items():
        o = old[name].to(t.dtype)
        if o.shape == t.shape:
            new[name] = o.clone()
            continue
        if t.dim() == 1:
            t[: o.shape[0]] = o
            continue
        transposed = name.startswith("up")  # ConvTranspose2d weights are [in, out, kh, kw]
        d_in, d_out = (0, 1) if transposed else (1, 0)
        halves = name in ("dec2.0.weight", "dec1.0.weight")  # cat([upsampled, skip])

        def places(dim, split):
            n_old, n_new = o.shape[dim], t.shape[dim]
            if split:
                return torch.cat([torch.arange(n_old // 2), n_new // 2 + torch.arange(n_old // 2)])
            return torch.arange(n_old)

        p_in, p_out = places(d_in, halves), places(d_out, False)
        keep = torch.zeros(t.shape[d_in], dtype=torch.bool)
        keep[p_in] = True
        if transposed:
            t[~keep] = 0
            t[p_in[:, None], p_out[None, :]] = o
        else:
            t[:, ~keep] = 0
            t[p_out[:, None], p_in[None, :]] = o
    model.load_state_dict(new)


def lovasz_softmax(logits, y):
    """The Lovasz-softmax loss (Berman et al. 2018), a convex surrogate of 1 - IoU, over the
    hand-part pixels of a batch and the parts present in it: the metric of Table 4.8 ignores
    background pixels, but calling a part pixel background counts against its part."""
    probs = F.softmax(logits, 1).permute(0, 2, 3, 1).reshape(-1, logits.shape[1])
    labels = y.reshape(-1)
    on = labels > 0
    probs, labels = probs[on], labels[on]
    losses = []
    for c in range(1, logits.shape[1]):
        fg = (labels == c).to(probs.dtype)
        if fg.sum() == 0:
            continue
        errors, order = torch.sort((fg - probs[:, c]).abs(), descending=True)
        fg = fg[order]
        inter = fg.sum() - fg.cumsum(0)
        union = fg.sum() + (1 - fg).cumsum(0)
        jaccard = 1 - inter / union
        jaccard[1:] = jaccard[1:] - jaccard[:-1]
        losses.append(torch.dot(errors, jaccard))
    return torch.stack(losses).mean() if losses else logits.sum() * 0


def load(dataset, task, test_fraction):
    rows = list(csv.DictReader(open(os.path.join(dataset, "labels.csv"))))
    if task == "segnet":
        rows = [r for r in rows if r["class"] == "hand"]
    subjects = sorted({int(r["subject"]) for r in rows})
    # The last 30% of the subjects are the test set: people the model never saw.
    # Rounded half up, as `skin eval` does, so both cut at the same subject.
    k = min(len(subjects) - 1, int(math.floor(len(subjects) * (1 - test_fraction) + 0.5)))
    cut = subjects[k] if len(subjects) > 1 else None
    images, targets, is_test = [], [], []
    for r in rows:
        img = np.asarray(Image.open(os.path.join(dataset, "images", r["file"])), dtype=np.uint8)
        images.append(img)
        if task == "handsnet":
            targets.append(0 if r["class"] == "hand" else 1)
        else:
            targets.append(np.asarray(Image.open(os.path.join(dataset, "masks", r["file"])), dtype=np.int64))
        is_test.append(cut is not None and int(r["subject"]) >= cut)
    x = torch.from_numpy(np.stack(images)[:, None].astype(np.float32) / 255.0)
    y = torch.from_numpy(np.stack(targets)) if task == "segnet" else torch.tensor(targets)
    t = torch.tensor(is_test)
    return x, y, t, rows, cut, len(subjects)


def flip(x, y, task):
    """App. C augmentation: random horizontal and vertical flips (of the mask too)."""
    if random.random() < 0.5:
        x = torch.flip(x, [3])
        y = torch.flip(y, [2]) if task == "segnet" else y
    if random.random() < 0.5:
        x = torch.flip(x, [2])
        y = torch.flip(y, [1]) if task == "segnet" else y
    return x, y


def median_frequency_weights(y):
    counts = torch.bincount(y.flatten(), minlength=len(PARTS)).double()
    freq = counts / counts.sum()
    present = freq[freq > 0]
    w = torch.where(freq > 0, present.median() / freq.clamp(min=1e-12), torch.zeros_like(freq))
    return w.float()


def evaluate(model, x, y, task, batch=256):
    model.eval()
    with torch.no_grad():
        preds = torch.cat([model(x[i : i + batch]).argmax(1) for i in range(0, len(x), batch)])
    if task == "handsnet":
        return {"accuracy": float((preds == y).float().mean())}
    # Thesis Table 4.8: over the pixels of hand parts, six classes.
    parts = y > 0
    gt, pr = y[parts], preds[parts]
    k = len(PARTS)
    cm = torch.bincount(gt * k + pr, minlength=k * k).reshape(k, k).double()[1:, :]
    tp = torch.tensor([cm[i, i + 1] for i in range(k - 1)])
    gt_n = cm.sum(1)
    pr_n = cm[:, 1:].sum(0)
    iou = tp / (gt_n + pr_n - tp).clamp(min=1)
    return {
        "pixel_accuracy": float(tp.sum() / gt_n.sum()),
        "mean_accuracy": float((tp / gt_n.clamp(min=1)).mean()),
        "miou": float(iou.mean()),
        "fwiou": float((gt_n / gt_n.sum() * iou).sum()),
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("task", choices=["handsnet", "segnet"])
    ap.add_argument("--arch", choices=["table4.1", "lean"], default="table4.1",
                    help="HandsNet: table4.1 (the thesis' layers) or lean (a sixth of the work, for the per-frame path)")
    ap.add_argument("--dataset", required=True, action="append",
                    help="directory written by `skin synth`; repeat to train on several (each split by its own subjects)")
    ap.add_argument("--out", required=True, help="ONNX file to write (a .pt and a .md card beside it)")
    ap.add_argument("--epochs", type=int, default=None, help="default: 80 (HandsNet), 100 (segmenter)")
    ap.add_argument("--lr", type=float, default=None, help="default: 0.01 (HandsNet), 0.05 (segmenter)")
    ap.add_argument("--lr-drop-factor", type=float, default=None, help="default: 0.2 / 0.1")
    ap.add_argument("--lr-drop-every", type=int, default=None, help="epochs; default: half the epochs")
    ap.add_argument("--optimizer", choices=["sgdm", "adam"], default="sgdm",
                    help="sgdm: SGD with momentum 0.9 (the thesis' MATLAB default); adam converges in fewer epochs")
    ap.add_argument("--batch", type=int, default=None, help="default: 64 (HandsNet), 16 (segmenter)")
    ap.add_argument("--test-fraction", type=float, default=0.3)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--init", help="fine-tune from this .pt (Ch. 5.4)")
    ap.add_argument("--first-convs-lr", type=float, default=1.0, help="lr factor of the first two convolutions (0.1 to fine-tune)")
    ap.add_argument("--swa-from", type=int, default=None, metavar="EPOCH",
                    help="export the average of the weights at the end of each epoch from EPOCH (1-based) on, "
                         "with batch-norm statistics recomputed on the training images (stochastic weight averaging)")
    ap.add_argument("--width", type=int, default=None,
                    help="segmenter: channels of its first level (default: those of --init, else 16); "
                         "with --init from a narrower model, that model is widened keeping its function")
    ap.add_argument("--lovasz", type=float, default=0.0, metavar="WEIGHT",
                    help="segmenter: add WEIGHT x the Lovasz-softmax loss (an IoU surrogate) to the cross-entropy")
    ap.add_argument("--test-every", type=int, default=5, metavar="EPOCHS",
                    help="score the test split every EPOCHS epochs, and after the last (default 5)")
    ap.add_argument("--smoke", action="store_true", help="one tiny epoch on a few images, then export and check")
    a = ap.parse_args()

    seg = a.task == "segnet"
    if not seg and (a.width is not None or a.lovasz != 0):
        ap.error("--width and --lovasz are options of the segmenter")
    if seg and a.arch != "table4.1":
        ap.error("--arch is an option of HandsNet")
    if a.lovasz < 0 or (a.width is not None and a.width < 1):
        ap.error("--width must be at least 1 and --lovasz at least 0")
    if a.test_every < 1:
        ap.error("--test-every must be at least 1")
    epochs = a.epochs or (100 if seg else 80)
    last = 1 if a.smoke else epochs
    if a.swa_from is not None and not 1 <= a.swa_from <= last:
        # Checked before the datasets load: nothing would be averaged, yet the card would say so.
        ap.error(f"--swa-from {a.swa_from}: the epochs are 1 to {last}")
    lr = a.lr or (0.001 if a.optimizer == "adam" else 0.05 if seg else 0.01)
    drop = a.lr_drop_factor or (0.1 if seg else 0.2)
    every = a.lr_drop_every or max(1, epochs // 2)
    batch = a.batch or (16 if seg else 64)
    torch.set_num_threads(a.threads)
    random.seed(a.seed)
    np.random.seed(a.seed)
    torch.manual_seed(a.seed)

    # The starting weights first: a wrong --width is an error before the datasets load.
    state = {k: v.float() for k, v in torch.load(a.init, map_location="cpu").items()} if a.init else None
    init_width = state["conv1.0.bias"].shape[0] if seg and state is not None else None
    width = a.width or init_width or 16
    if init_width is not None and width < init_width:
        sys.exit(f"--width {width}: {a.init} has {init_width} channels; a model can be widened, not narrowed")

    # Each dataset split by its own subjects, then put together.
    loaded = [load(d, a.task, a.test_fraction) for d in a.dataset]
    x, y, test = (torch.cat([d[i] for d in loaded]) for i in range(3))
    cut = ", ".join(str(d[4]) for d in loaded)
    n_subjects = ", ".join(str(d[5]) for d in loaded)
    if a.smoke:
        n = min(48, len(x))
        x, y, test = x[:n], y[:n], torch.zeros(n, dtype=torch.bool)
        test[-max(1, n // 3):] = True
        epochs = 1
    xtr, ytr, xte, yte = x[~test], y[~test], x[test], y[test]
    _, _, rows_px, cols_px = x.shape
    print(f"{a.task}: {len(xtr)} training and {len(xte)} test images ({rows_px} x {cols_px}); "
          f"test subjects >= {cut} of {n_subjects}", flush=True)

    if seg:
        model = HandSeg(width)
    else:
        model = (LeanHandsNet if a.arch == "lean" else HandsNet)(rows_px, cols_px)
    if state is not None:
        if init_width is not None and init_width < width:
            widen(state, model)
        else:
            missing = set(model.state_dict()) ^ set(state)
            if missing:
                arch = "" if seg else f" (--arch {a.arch})"
                sys.exit(f"--init {a.init}: its weights are not those of this model{arch}: "
                         f"{', '.join(sorted(missing)[:4])} ...; a lean HandsNet needs --arch lean")
            model.load_state_dict(state)
    first = {id(p) for p in model.first_convs()}
    groups = [
        {"params": [p for p in model.parameters() if id(p) in first], "lr": lr * a.first_convs_lr},
        {"params": [p for p in model.parameters() if id(p) not in first], "lr": lr},
    ]
    if a.optimizer == "adam":
        opt = torch.optim.Adam(groups, weight_decay=1e-5)
    else:
        opt = torch.optim.SGD(groups, momentum=0.9, weight_decay=1e-4)
    sched = torch.optim.lr_scheduler.StepLR(opt, step_size=every, gamma=drop)
    weights = median_frequency_weights(ytr) if seg else None
    loss_fn = nn.CrossEntropyLoss(weight=weights)

    swa = torch.optim.swa_utils.AveragedModel(model) if a.swa_from is not None else None
    start = time.time()
    for epoch in range(epochs):
        model.train()
        order = torch.randperm(len(xtr))
        total = 0.0
        for i in range(0, len(order), batch):
            idx = order[i : i + batch]
            if len(idx) < 2:
                continue
            xb, yb = flip(xtr[idx], ytr[idx], a.task)
            opt.zero_grad()
            out = model(xb)
            loss = loss_fn(out, yb)
            if seg and a.lovasz > 0:
                loss = loss + a.lovasz * lovasz_softmax(out, yb)
            loss.backward()
            opt.step()
            total += float(loss.detach()) * len(idx)
        sched.step()
        if swa is not None and epoch + 1 >= a.swa_from:
            swa.update_parameters(model)
        line = f"epoch {epoch + 1}/{epochs}: loss {total / max(1, len(xtr)):.4f}"
        if len(xte) and ((epoch + 1) % a.test_every == 0 or epoch + 1 == epochs):
            line += "  test " + ", ".join(f"{k} {v:.4f}" for k, v in evaluate(model, xte, yte, a.task).items())
        print(f"{line}  ({time.time() - start:.0f} s)", flush=True)

    if swa is not None:
        # The averaged weights need batch-norm statistics of their own.
        torch.optim.swa_utils.update_bn([xtr[i : i + 256] for i in range(0, len(xtr), 256)], swa)
        model = swa.module
        print(f"averaged the weights of epochs {a.swa_from} to {epochs}", flush=True)
    scores = evaluate(model, xte, yte, a.task) if len(xte) else {}
    export(model, a, rows_px, cols_px, seg, scores, dict(
        **({"width": width} if seg else {"arch": a.arch}), **({"lovasz": a.lovasz} if seg and a.lovasz > 0 else {}),
        optimizer=a.optimizer, epochs=epochs, lr=lr, lr_drop_factor=drop, lr_drop_every=epochs if every >= epochs else every,
        **({"swa_from": a.swa_from} if swa is not None else {}),
        batch=batch, train_images=len(xtr), test_images=len(xte), subjects=n_subjects,
        test_subjects_from=cut, seconds=round(time.time() - start)))


def export(model, a, rows, cols, seg, scores, info):
    model.eval()
    os.makedirs(os.path.dirname(os.path.abspath(a.out)), exist_ok=True)
    dummy = torch.zeros(1, 1, rows, cols)
    # HandsNet ends in a softmax (Table 4.1): the exported model gives probabilities.
    net = model if seg else nn.Sequential(model, nn.Softmax(dim=1)).eval()
    # The classic exporter, opset 17, dynamic batch; value_info stripped so that tract can
    # unify the symbolic batch with a concrete one.
    torch.onnx.export(net, dummy, a.out, dynamo=False, opset_version=17,
                      input_names=["image"], output_names=["parts" if seg else "probabilities"],
                      dynamic_axes={"image": {0: "N"}, ("parts" if seg else "probabilities"): {0: "N"}})
    import onnx

    m = onnx.load(a.out)
    del m.graph.value_info[:]
    onnx.checker.check_model(m)
    onnx.save(m, a.out)
    stem = os.path.splitext(a.out)[0]
    torch.save({k: v.half() for k, v in model.state_dict().items()}, stem + ".pt")

    classes = PARTS if seg else ["hand", "non_hand"]
    card = [
        "---",
        "model: " + ("hand-part segmentation (compact encoder-decoder)" if seg
                     else "HandsNet, lean (16-128 channels)" if a.arch == "lean" else "HandsNet (thesis Table 4.1)"),
        f"input: [N, 1, {rows}, {cols}] grey",
        "input_scale: unit",
        f"output: {'[N, 7, ' + str(rows) + ', ' + str(cols) + '] part scores' if seg else '[N, 2] probabilities (softmax)'}",
        f"classes: {', '.join(classes)}",
        "---",
        "",
        f"# {os.path.basename(a.out)}",
        "",
        "Trained by `skin-learn/training/train.py` on " + ", ".join(f"`{d}`" for d in a.dataset) + " (written by `skin synth`).",
        "",
        "Input: tactile images through the real pipeline (1 mm grid, contact-max grey, erosion 2 /",
        "dilation 4, resized), pixel values divided by 255 (input_scale: unit).",
        "",
        f"Split by subject: subjects >= {info['test_subjects_from']} of {info['subjects']} are the test set "
        f"({info['test_images']} images; {info['train_images']} for training).",
        "",
        "Training: " + ", ".join(f"{k} {v}" for k, v in info.items() if k not in ("train_images", "test_images", "subjects", "test_subjects_from")) + ", seed " + str(a.seed) + ".",
        "",
        "Test scores measured by the training script (PyTorch): " + (", ".join(f"{k} {v:.4f}" for k, v in scores.items()) or "none") + ".",
        "The figures of record are those of `skin eval` (tract), in the project's README.",
        "",
        "Reproduce:",
        "",
        "```",
        " ".join(["python", "skin-learn/training/train.py"] + sys.argv[1:]),
        "```",
        "",
    ]
    with open(stem + ".md", "w") as f:
        f.write("\n".join(card))
    print(f"wrote {a.out}, {stem}.pt, {stem}.md", flush=True)


if __name__ == "__main__":
    main()
