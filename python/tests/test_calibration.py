"""Calibration from probe arrays, equal to `skin calibrate`; flagged taxels stay flagged."""

import csv

import numpy as np
import pytest

import skin
from conftest import FIXTURES, run_skin

PROBES = FIXTURES / "hex_patch" / "probes.csv"


def cli_report(tmp_path, probes):
    run_skin("calibrate", probes, "-o", tmp_path / "layout.json", "--report", tmp_path / "report.tsv")
    with open(tmp_path / "report.tsv") as f:
        return list(csv.DictReader(f, delimiter="\t"))


def test_calibration_equals_skin_calibrate(tmp_path):
    data = skin.read_probes(PROBES)
    k, n = data["responses"].shape
    assert data["centroids"].shape == (k, 3) and data["ids"].shape == (n,)
    cal = skin.calibrate(data["centroids"], data["ids"], data["responses"])
    rows = cli_report(tmp_path, PROBES)
    assert [int(r["taxel"]) for r in rows] == cal.ids.tolist()
    assert [r["status"] for r in rows] == cal.status
    for r, p, sd in zip(rows, cal.positions, cal.centre_sd_mm):
        if r["status"] == "fitted":
            np.testing.assert_allclose(p, [float(r["x_m"]), float(r["y_m"]), float(r["z_m"])], atol=5e-7)
            assert sd == pytest.approx(float(r["centre_sd_mm"]), abs=5e-4)
        else:
            assert np.isnan(p).all()
    assert cal.to_tsv() == (tmp_path / "report.tsv").read_text()
    assert cal.fitted.sum() == sum(r["status"] == "fitted" for r in rows) > 0
    np.testing.assert_allclose(np.linalg.norm(cal.normals[cal.fitted], axis=1), 1.0, atol=1e-9)


def test_simulated_probe_finds_the_taxels(tmp_path):
    # A known answer: the probe simulator's taxels are where the layout puts them.
    probes = tmp_path / "probes.csv"
    run_skin("probe-sim", "--layout", FIXTURES / "hex_patch" / "layout.json", "--contacts", "3000", "--seed", "3", "-o", probes)
    data = skin.read_probes(probes)
    cal = skin.calibrate(data["centroids"], data["ids"], data["responses"])
    truth = skin.read_layout(FIXTURES / "hex_patch" / "layout.json")[0]
    where = {int(i): p for i, p in zip(truth.ids, truth.positions)}
    errors = [np.linalg.norm(p - where[int(i)]) for i, p, ok in zip(cal.ids, cal.positions, cal.fitted) if ok]
    assert len(errors) > 0.5 * len(truth)
    assert np.median(errors) < 0.002  # 2 mm


def test_a_taxel_that_never_answered_is_flagged_not_guessed():
    data = skin.read_probes(PROBES)
    ids = np.append(data["ids"], 9999)
    responses = np.hstack([data["responses"], np.zeros((len(data["centroids"]), 1))])
    cal = skin.calibrate(data["centroids"], ids, responses)
    last = cal.ids.tolist().index(9999)
    assert not cal.fitted[last] and np.isnan(cal.positions[last]).all()
    assert cal.status[last] == "every response is zero"


def test_bad_probe_arrays_are_named():
    data = skin.read_probes(PROBES)
    with pytest.raises(skin.ArrayError, match="responses: shape"):
        skin.calibrate(data["centroids"], data["ids"], data["responses"][:, :-1])
    bad = data["centroids"].copy()
    bad[3, 1] = np.nan
    with pytest.raises(skin.ArrayError, match=r"centroids: NaN at index \[3, 1\]"):
        skin.calibrate(bad, data["ids"], data["responses"])
    with pytest.raises(skin.ArrayError, match="min_responses"):
        skin.calibrate(data["centroids"], data["ids"], data["responses"], min_responses=3)
    with pytest.raises(skin.InputError, match="nope.csv"):
        skin.read_probes(FIXTURES / "nope.csv")
