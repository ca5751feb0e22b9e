"""LLAMAS through `run` (probability maps <frame>.json_<c>.png, a recording a clip) and the AP of
probability maps through `score llamas --maps` (evaluate_segmentation.py --multi_class)."""

from __future__ import annotations

import csv
import json
import io
from pathlib import Path

import cv2
import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st

from roneld_eval.cli import main
from roneld_eval.maps.scnn_png import read_grey_png
from roneld_eval.benchmarks.llamas.segmentation import approx_auc


def _official_auc(prediction: np.ndarray, label: np.ndarray) -> dict:
    """segmentation_metrics.binary_approx_auc (unsupervised_llamas 9b99f46) as written: the image
    thresholded 101 times. The twin of approx_auc's one histogram."""
    prediction = prediction.astype(float) / 255
    corner_precision = corner_recall = corner_auc = corner_threshold = 0
    precisions, recalls, auc_value = [1], [0], 0
    for i in range(101):
        threshold = (100 - i) / 100
        binary = (prediction >= threshold).astype(int)
        tp = np.sum(np.logical_and(label != 0, binary == label))
        fn = np.sum(np.logical_and(label != 0, binary == 0))
        fp = np.sum(np.logical_and(label == 0, binary != 0))
        precision = 0 if (tp + fp) == 0 else tp / (tp + fp)
        recall = 0 if (tp + fn) == 0 else tp / (tp + fn)
        if (precision * recall) > corner_auc:
            corner_auc = precision * recall
            corner_precision, corner_recall, corner_threshold = precision, recall, threshold
        precisions.append(precision)
        recalls.append(recall)
        auc_value += (recalls[-1] - recalls[-2]) * precisions[-2]
    return {"recall": corner_recall, "precision": corner_precision, "threshold": corner_threshold, "auc": auc_value}


# grey values whose v / 255 sits on or beside a threshold t / 100 (v = 51 k is exactly 0.2 k)
EDGES = sorted({v for k in range(6) for v in (51 * k - 1, 51 * k, 51 * k + 1) if 0 <= v <= 255})


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), palette=st.sampled_from(["any", "edges", "two"]), density=st.floats(0, 1))
def test_one_histogram_gives_the_scripts_101_thresholdings(seed, palette, density):
    rng = np.random.default_rng(seed)
    shape = (int(rng.integers(1, 40)), int(rng.integers(1, 40)))
    values = {"any": np.arange(256), "edges": np.array(EDGES), "two": rng.integers(0, 256, 2)}[palette]
    prediction = rng.choice(values, shape).astype(np.uint8)
    label = rng.random(shape) < density
    ours = approx_auc(prediction, label)
    theirs = _official_auc(prediction, label.astype(np.uint8))
    assert (ours.recall, ours.precision, ours.threshold, ours.auc) == \
        (theirs["recall"], theirs["precision"], theirs["threshold"], theirs["auc"])


def _png(path, image, *params):
    path.parent.mkdir(parents=True, exist_ok=True)
    assert cv2.imwrite(str(path), image, list(params))
    return path


def test_maps_are_read_as_opencvs_imread_greyscale_reads_them(tmp_path):
    rng = np.random.default_rng(4)
    grey = rng.integers(0, 256, (30, 40), dtype=np.uint8)
    colour = rng.integers(0, 256, (30, 40, 3), dtype=np.uint8)  # channels differ: weighted to grey
    deep = rng.integers(0, 65536, (30, 40), dtype=np.uint16)  # 16 bits: cut to 8
    same = np.repeat(grey[..., None], 3, axis=2)  # RGB holding grey: the fast path
    for name, image in (("grey", grey), ("colour", colour), ("deep", deep), ("same", same)):
        path = _png(tmp_path / f"{name}.png", image)
        assert np.array_equal(read_grey_png(path), cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)), name


def _synth(tmp_path, clips=2, frames=5):
    result = CliRunner().invoke(main, ["synth", "--dataset", "llamas", "--maps-format", "llamas-png", "--out",
                                       str(tmp_path / "set"), "--clips", str(clips), "--frames", str(frames)])
    assert result.exit_code == 0, result.output
    return tmp_path / "set" / "labels", tmp_path / "set" / "predictions"


def _rows(path) -> list[dict]:
    return list(csv.DictReader(io.StringIO(path.read_text())))


@pytest.fixture(scope="module")
def llamas_run(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("llamas")
    labels, maps = _synth(tmp)
    result = CliRunner().invoke(main, ["run", "--dataset", "llamas", "--data-root", str(labels), "--maps-root",
                                       str(maps), "--out", str(tmp / "run"), "--save-lanes", "--workers", "1"])
    assert result.exit_code == 0, result.output
    return labels, maps, tmp / "run"


def test_a_run_on_llamas_maps_scores_its_lanes_as_score_llamas_does(llamas_run, tmp_path):
    labels, _, run = llamas_run
    official = _rows(run / "official.csv")
    assert {row["method"] for row in official} == {"baseline", "roneld"}
    result = CliRunner().invoke(main, ["score", "llamas", "--labels", str(labels), "--pred-root", str(run / "lanes"),
                                       "--out", str(tmp_path / "scores"), "--quiet"])
    assert result.exit_code == 0, result.output
    scored = {(row["method"], row["threshold"]): row for row in _rows(tmp_path / "scores" / "official.csv")}
    summary = {row["method"]: row for row in _rows(tmp_path / "scores" / "summary.csv")}
    compared = 0
    for row in official:
        if row["category"] != "all":
            continue
        other = scored[(row["method"], row["threshold"])]
        assert [row[k] for k in ("tp", "fp", "fn", "precision", "recall", "f1")] == \
            [other[k] for k in ("tp", "fp", "fn", "precision", "recall", "f1")]
        assert row["mf1"] == summary[row["method"]]["mf1"]
        compared += 1
    assert compared == 20 and int(official[0]["tp"]) > 0
    # the ego rows: the two ego lanes of each frame, at most two predicted
    ego = [row for row in official if row["category"] == "ego" and row["threshold"] == "0.50"]
    assert all(int(row["tp"]) + int(row["fn"]) == 2 * 10 for row in ego)


def test_compare_shows_llamas_official_table(llamas_run, tmp_path):
    _, _, run = llamas_run
    result = CliRunner().invoke(main, ["compare", str(run), "--out", str(tmp_path / "cmp")])
    assert result.exit_code == 0, result.output
    table = (tmp_path / "cmp" / "table_official.md").read_text()
    baseline = next(row for row in _rows(run / "official.csv")
                    if (row["method"], row["category"], row["threshold"]) == ("baseline", "all", "0.50"))
    assert f"| segmentation | all | {100 * float(baseline['f1']):.2f} |" in table


def test_score_llamas_gives_the_ap_of_maps_beside_the_f1_of_lanes(llamas_run, tmp_path):
    labels, maps, run = llamas_run
    result = CliRunner().invoke(main, ["score", "llamas", "--labels", str(labels), "--pred-root",
                                       f"seg={run / 'lanes' / 'baseline'}", "--maps", f"seg={maps}",
                                       "--maps", f"alone={maps}", "--out", str(tmp_path / "s"), "--quiet"])
    assert result.exit_code == 0, result.output
    rows = _rows(tmp_path / "s" / "official.csv")
    assert [row["method"] for row in rows] == ["seg"] * 10 + ["alone"]
    alone = rows[-1]
    assert alone["threshold"] == alone["tp"] == alone["f1"] == ""
    aps = [float(alone[f"ap_{name}"]) for name in ("l1", "l0", "r0", "r1")]
    assert all(0 < ap < 1 for ap in aps) and float(alone["ap_mean"]) == pytest.approx(sum(aps) / 4, abs=1e-6)
    assert all(row[f"ap_{name}"] == alone[f"ap_{name}"] for row in rows for name in ("l1", "l0", "r0", "r1", "mean"))
    summary = (tmp_path / "s" / "summary.md").read_text()
    assert "AP mean (%)" in summary and "evaluate_segmentation.py" in summary


def _bad_score(tmp_path, labels, maps):
    result = CliRunner().invoke(main, ["score", "llamas", "--labels", str(labels), "--maps", str(maps),
                                       "--out", str(tmp_path / "o"), "--quiet"])
    assert result.exit_code != 0 and "Traceback" not in result.output
    assert not (tmp_path / "o" / "official.csv").exists()
    return result.output


def test_maps_missing_or_of_another_size_are_named(tmp_path):
    labels, maps = _synth(tmp_path, clips=1, frames=3)
    first = sorted(maps.rglob("*.json_3.png"))[1]
    data = first.read_bytes()
    first.unlink()
    output = _bad_score(tmp_path, labels, maps)
    assert f"{first}: file not found" in output
    _png(first, np.zeros((288, 800), np.uint8))
    output = _bad_score(tmp_path, labels, maps)
    assert str(first) in output and "800x288" in output and "1276x717" in output
    first.write_bytes(data)
    for name in sorted(maps.rglob("*.json_1.png")):
        name.unlink()
    output = _bad_score(tmp_path, labels, maps)
    assert "no prediction file of the list" in output


def test_nothing_to_score_says_what_to_give(tmp_path):
    labels, _ = _synth(tmp_path, clips=1, frames=1)
    result = CliRunner().invoke(main, ["score", "llamas", "--labels", str(labels)])
    assert result.exit_code != 0 and "--pred-root" in result.output and "--maps" in result.output


def test_synth_llamas_writes_lane_files_unless_told(tmp_path):
    result = CliRunner().invoke(main, ["synth", "--dataset", "llamas", "--out", str(tmp_path / "s"), "--clips", "1",
                                       "--frames", "2"])
    assert result.exit_code == 0, result.output
    assert "score llamas" in result.output and list((tmp_path / "s").rglob("*.lines.txt"))
    assert not list((tmp_path / "s").rglob("*.png"))
    result = CliRunner().invoke(main, ["synth", "--dataset", "llamas", "--out", str(tmp_path / "n"),
                                       "--maps-format", "npy"])
    assert result.exit_code != 0 and "llamas-png or lanes" in result.output


GOLDEN_AP = Path(__file__).parent / "golden" / "llamas_ap"


def test_the_ap_of_every_image_and_its_mean_are_the_official_scripts():
    # unsupervised_llamas 9b99f46 evaluate_segmentation.py --multi_class, run unchanged on these files
    # (tests/golden/llamas_ap/README.md): every image's four numbers per class, and the means
    from roneld_eval.benchmarks.llamas.score import _class_curves, _segmentation_label, score_llamas
    from roneld_eval.benchmarks.llamas.reader import every_label, read_record

    expected = json.loads((GOLDEN_AP / "expected.json").read_text())
    labels = GOLDEN_AP / "labels" / "valid"
    methods = sorted(expected["per_image"])
    assert methods == ["blocks", "odd", "soft"]
    compared = 0
    for key, path in every_label(labels).items():
        masks = _segmentation_label(read_record(path), path)
        for method in methods:
            for c, curve in enumerate(_class_curves(GOLDEN_AP / "pred" / method, key, masks), start=1):
                want = expected["per_image"][method][key][str(c)]
                assert (curve.recall, curve.precision, curve.threshold, curve.auc) == \
                    (want["recall"], want["precision"], want["threshold"], want["auc"]), (method, key, c)
                compared += 1
    assert compared == 12 * 3 * 4
    score = score_llamas(labels, maps={m: GOLDEN_AP / "pred" / m for m in methods}, workers=1)
    for method in methods:
        for c, curve in enumerate(score.segmentation[method], start=1):
            want = expected["mean_sorted"][method][str(c)]
            assert (curve.recall, curve.precision, curve.threshold, curve.auc) == \
                (want["recall"], want["precision"], want["threshold"], want["auc"])
            walked = expected["mean_walk_order"][method][str(c)]["auc"]
            assert abs(curve.auc - walked) <= 4e-16  # the script's file-system order: the last bits only


def test_on_a_detectors_lane_files_the_baseline_is_the_detector_scored_as_score_llamas_scores_it(tmp_path):
    result = _invoke_synth_lanes(tmp_path)
    labels, lanes = tmp_path / "set" / "labels", tmp_path / "set" / "predictions"
    result = CliRunner().invoke(main, ["run", "--dataset", "llamas", "--data-root", str(labels), "--maps-root",
                                       str(lanes), "--maps-format", "lanes", "--out", str(tmp_path / "run"),
                                       "--workers", "1", "--quiet"])
    assert result.exit_code == 0, result.output
    result = CliRunner().invoke(main, ["score", "llamas", "--labels", str(labels), "--pred-root", f"baseline={lanes}",
                                       "--out", str(tmp_path / "s"), "--quiet"])
    assert result.exit_code == 0, result.output
    scored = {row["threshold"]: row for row in _rows(tmp_path / "s" / "official.csv")}
    run = [row for row in _rows(tmp_path / "run" / "official.csv") if (row["method"], row["category"]) ==
           ("baseline", "all")]
    assert len(run) == 10 and all([row[k] for k in ("tp", "fp", "fn", "f1")] ==
                                  [scored[row["threshold"]][k] for k in ("tp", "fp", "fn", "f1")] for row in run)


def _invoke_synth_lanes(tmp_path):
    result = CliRunner().invoke(main, ["synth", "--dataset", "llamas", "--out", str(tmp_path / "set"), "--clips", "2",
                                       "--frames", "4"])
    assert result.exit_code == 0, result.output
    return result


def test_saved_lanes_are_read_back_where_score_llamas_looks_for_them(tmp_path):
    """`run --save-lanes` names a frame's file by its key (<recording>/<frame>, as evaluate.py
    does); `--maps-format lanes` reads the same names back, also with the recordings one folder
    below the data root (where the key is not the frame's path)."""
    labels, maps = _synth(tmp_path, clips=2, frames=3)
    root = tmp_path / "root"
    (root / "labels").mkdir(parents=True)
    (root / "maps").mkdir()
    labels.rename(root / "labels" / "valid")
    maps.rename(root / "maps" / "valid")
    first = tmp_path / "from-maps"
    result = CliRunner().invoke(main, ["run", "--dataset", "llamas", "--data-root", str(root / "labels"),
                                       "--maps-root", str(root / "maps"), "--methods", "baseline", "--save-lanes",
                                       "--workers", "1", "--quiet", "--out", str(first)])
    assert result.exit_code == 0, result.output
    second = tmp_path / "from-lanes"
    result = CliRunner().invoke(main, ["run", "--dataset", "llamas", "--data-root", str(root / "labels"),
                                       "--maps-root", str(first / "lanes" / "baseline"), "--maps-format", "lanes",
                                       "--methods", "baseline", "--workers", "1", "--quiet", "--out", str(second)])
    assert result.exit_code == 0, result.output
    assert _rows(second / "official.csv") == _rows(first / "official.csv")
