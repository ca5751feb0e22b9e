"""`score once3d` against ONCE-3DLanes' evaluator (goldens in tests/golden/once3d, each with the
tool's commit and stack), its Munkres and GEOS distance written out, its refusals, shards and the
metric in memory."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from roneld_eval.benchmarks.once3d import official, reader
from roneld_eval.benchmarks.once3d.matching import munkres_pairs
from roneld_eval.benchmarks.once3d.official import frame_counts, totals
from roneld_eval.benchmarks.once3d.reader import read_prediction, read_truth
from roneld_eval.benchmarks.once3d.score import score_once3d
from roneld_eval.benchmarks.once3d.synth import synth_once3d
from roneld_eval.cli import main

GOLDEN = Path(__file__).parent / "golden" / "once3d"


def invoke(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


@pytest.fixture(scope="module", params=[0, 1])
def golden_set(request, tmp_path_factory):
    golden = json.loads((GOLDEN / f"synth_seed{request.param}.json").read_text())
    assert golden["set"]["command"].endswith(f"--clips 8 --frames 5 --seed {request.param}")
    out = tmp_path_factory.mktemp(f"once{request.param}")
    synth_once3d(out, clips=8, frames=5, seed=request.param)
    return out, golden


def _counts(root: Path, relpath: str):
    lanes, scores = read_prediction(root / "predictions" / relpath)
    return frame_counts(read_truth(root / "labels" / relpath), lanes, scores)


def test_every_frame_at_every_threshold_is_the_evaluators_pair_for_pair_and_bit_for_bit(golden_set):
    root, golden = golden_set
    true_positives = 0
    for frame in golden["frames"]:
        counts = _counts(root, frame["frame"])
        assert counts.stacked().tolist() == frame["counts"], frame["frame"]
        assert [[list(pair) for pair in pairs] for pairs in counts.pairs] == frame["pairs"], frame["frame"]
        true_positives += sum(frame["counts"][2])
    assert len(golden["frames"]) == 40 and true_positives > 300


def test_the_float32_sums_and_the_printed_table_are_the_evaluators_in_its_order(golden_set):
    """The sums follow the order the evaluator's folders listed the frames (its workers' float32
    sums depend on it); the golden keeps that order."""
    root, golden = golden_set
    counts = np.array([_counts(root, relpath).stacked() for relpath in golden["order"]])
    total = totals(counts)
    for t, (row, sums) in enumerate(zip(golden["table"], golden["sums"], strict=True)):
        assert row == [official.LABELS[t], *(official.printed(v[t]) for v in (total.f1, total.precision, total.recall,
                                                                             total.distance))]
        assert [float(total.gt[t]), float(total.pred[t]), float(total.tp[t]), float(total.distance_sum[t])] == sums


def test_the_command_sums_in_the_order_the_folders_list_the_frames(golden_set, monkeypatch, tmp_path):
    root, golden = golden_set
    listed: dict[str, list[str]] = {str(root / "labels"): []}  # each folder as the evaluator's machine listed it
    for relpath in golden["order"]:
        segment, _, name = relpath.split("/")
        if segment not in listed[str(root / "labels")]:
            listed[str(root / "labels")].append(segment)
        listed.setdefault(str(root / "labels" / segment / "cam01"), []).append(name)
    real = os.listdir
    monkeypatch.setattr(reader.os, "listdir", lambda path: listed.get(str(path), None) or real(path))
    result = invoke("score", "once3d", "--labels", root / "labels", "--pred-root", root / "predictions", "--out",
                    tmp_path / "out", "--workers", "2")
    assert result.exit_code == 0, result.output
    for row in golden["table"]:
        mark = " (PersFormer's)" if row[0] == "0.95" else ""
        assert f"| {row[0]}{mark} | " + " | ".join(row[1:]) + " |" in result.output
    summary = (tmp_path / "out" / "summary.md").read_text()
    assert "| 0.95 (PersFormer's) | " + " | ".join(golden["table"][-1][1:]) in summary
    assert len((tmp_path / "out" / "official.csv").read_text().splitlines()) == 1 + 18


def test_munkres_breaks_ties_as_the_package_does():
    """400 matrices of few distinct costs (ties everywhere), each with the pairs munkres 1.1.4 returned."""
    golden = json.loads((GOLDEN / "munkres_ties.json").read_text())
    assert golden["tool"].startswith("munkres 1.1.4")
    for case in golden["cases"]:
        assert [list(pair) for pair in munkres_pairs(case["cost"])] == case["pairs"], case["cost"]
    assert sum(len(case["cost"]) != len(case["cost"][0]) for case in golden["cases"]) > 200  # rectangular: padded


def test_the_distance_leaves_depth_out_as_geos_does():
    gt = np.column_stack([np.zeros(5), np.full(5, 1.6), np.linspace(5, 40, 5)])
    deeper = gt * [1, 1, 1.3]
    assert official.mean_distance(gt, deeper) == 0.0
    lifted = gt + [0, 0.35, 0]
    assert official.mean_distance(gt, lifted) == pytest.approx(0.35)


def test_a_score_at_a_threshold_is_dropped_there():
    lane = np.column_stack([np.zeros(5), np.full(5, 1.6), np.linspace(2, 40, 5)])
    counts = frame_counts([lane], [lane, lane, lane], [0.35, 0.35000000000000003, 0.3500000000000001])
    at = official.LABELS.index("0.35")
    assert counts.pred[at] == 1.0 and counts.pred[at - 1] == 3.0  # only 0.3500000000000001 is above 35 * 0.01


def _frame(root: Path, labels: dict, preds: dict | None, name="000001/cam01/1.json") -> None:
    for sub, record in (("labels", labels), ("predictions", preds)):
        if record is not None:
            (root / sub / name).parent.mkdir(parents=True, exist_ok=True)
            (root / sub / name).write_text(json.dumps(record))


LANE = [[0.0, 1.6, 3.0], [0.1, 1.6, 20.0], [0.2, 1.6, 45.0]]


@pytest.mark.parametrize("labels, preds, says", [
    ({"lanes": [LANE]}, {"lanes": [{"points": LANE}]}, "lane 0: `score` must be a number, got None"),
    ({"lanes": [LANE]}, {"lanes": [{"points": LANE, "score": "0.8"}]}, "`score` must be a number, got '0.8'"),
    ({"lanes": [LANE]}, {"lanes": [{"points": LANE[:1], "score": 0.5}]}, "at least 2 points where its score"),
    ({"lanes": [LANE]}, {"lanes": [LANE]}, "lane 0: must be {\"points\""),
    ({"lanes": [{"points": LANE, "score": 1}]}, {"lanes": []}, "a label's lane is a bare list of points"),
    ({"lanes": [[[0.0, 1.6]]]}, {"lanes": []}, "lane 0: must be a list of [x, y, z] points"),
    ({"lane": []}, {"lanes": []}, "a JSON object with a `lanes` list is expected"),
])
def test_bad_files_are_refused_in_one_line_naming_the_file(tmp_path, labels, preds, says):
    _frame(tmp_path, labels, preds)
    result = invoke("score", "once3d", "--labels", tmp_path / "labels", "--pred-root", tmp_path / "predictions",
                    "--workers", 1)
    assert result.exit_code != 0 and "Traceback" not in result.output
    assert says in result.output, result.output


def test_the_layout_the_evaluator_needs_is_named(tmp_path):
    (tmp_path / "labels" / "000001").mkdir(parents=True)
    (tmp_path / "labels" / "000001" / "1.json").write_text(json.dumps({"lanes": []}))
    (tmp_path / "predictions").mkdir()
    result = invoke("score", "once3d", "--labels", tmp_path / "labels", "--pred-root", tmp_path / "predictions")
    assert result.exit_code != 0 and "has no cam01 folder" in result.output
    (tmp_path / "labels" / "list.txt").write_text("")
    result = invoke("score", "once3d", "--labels", tmp_path / "labels", "--pred-root", tmp_path / "predictions")
    assert result.exit_code != 0 and "not a segment folder" in result.output


def test_the_iou_gate_is_labelled_and_only_removes_true_positives(golden_set, tmp_path):
    root, _ = golden_set
    plain = score_once3d(root / "labels", root / "predictions", workers=1)
    gated = score_once3d(root / "labels", root / "predictions", iou_gate=0.3, workers=1)
    assert "NOT the official evaluator" in gated.describe() and "as coded" in plain.describe()
    for threshold in ("0.1", "0.5", "0.95"):
        assert gated.value("predictions", "tp", threshold) <= plain.value("predictions", "tp", threshold)
        assert gated.value("predictions", "pred_lanes", threshold) == plain.value("predictions", "pred_lanes",
                                                                                  threshold)
    assert gated.value("predictions", "tp", "0.1") < plain.value("predictions", "tp", "0.1")


def test_shards_merge_into_the_unsharded_files_byte_for_byte(tmp_path):
    synth_once3d(tmp_path / "set", clips=5, frames=4, seed=3)
    labels, preds = tmp_path / "set" / "labels", tmp_path / "set" / "predictions"
    whole = invoke("score", "once3d", "--labels", labels, "--pred-root", preds, "--out", tmp_path / "whole",
                   "--workers", 1)
    assert whole.exit_code == 0, whole.output
    for k in (1, 2):
        part = invoke("score", "once3d", "--labels", labels, "--pred-root", preds, "--out", tmp_path / f"p{k}",
                      "--shard", f"{k}/2", "--workers", 1)
        assert part.exit_code == 0, part.output
    merged = invoke("merge", tmp_path / "p1", tmp_path / "p2", "--out", tmp_path / "merged")
    assert merged.exit_code == 0, merged.output
    for name in ("official.csv", "summary.md"):
        assert (tmp_path / "merged" / name).read_bytes() == (tmp_path / "whole" / name).read_bytes(), name


def test_the_metric_in_memory_gives_what_the_command_writes(golden_set):
    import roneld_eval

    root, _ = golden_set
    metric = roneld_eval.metric("once3d", labels=root / "labels")
    for relpath in reader.listed_frames(root / "labels"):
        lanes, scores = read_prediction(root / "predictions" / relpath)
        metric.update(relpath, list(lanes), list(scores))
    computed = metric.compute()
    score = score_once3d(root / "labels", root / "predictions", workers=1)
    assert computed["f1"] == score.value("predictions", "f1") or np.isnan(computed["f1"])
    assert computed["recall@0.5"] == score.value("predictions", "recall", "0.5")
    assert computed["distance_error@0.1"] == score.value("predictions", "distance_error", "0.1")


def test_synth_is_deterministic(tmp_path):
    synth_once3d(tmp_path / "a", clips=2, frames=3, seed=9)
    synth_once3d(tmp_path / "b", clips=2, frames=3, seed=9)
    for path in sorted((tmp_path / "a").rglob("*.json")):
        assert (tmp_path / "b" / path.relative_to(tmp_path / "a")).read_bytes() == path.read_bytes()


def test_an_out_folder_inside_the_labels_is_not_read_as_a_segment(tmp_path):
    synth_once3d(tmp_path / "set", clips=2, frames=2, seed=5)
    labels, preds = tmp_path / "set" / "labels", tmp_path / "set" / "predictions"
    first = invoke("score", "once3d", "--labels", labels, "--pred-root", preds, "--out", labels / "scores")
    assert first.exit_code == 0, first.output
    again = invoke("score", "once3d", "--labels", labels, "--pred-root", preds, "--out", tmp_path / "again")
    assert again.exit_code == 0, again.output
    assert (labels / "scores" / "official.csv").read_text() == (tmp_path / "again" / "official.csv").read_text()


def test_the_metric_in_memory_refuses_what_the_files_may_not_hold(golden_set):
    import roneld_eval
    from roneld_eval.in_memory import MetricInputError

    root, golden = golden_set
    metric = roneld_eval.metric("once3d", labels=root / "labels")
    lane = np.column_stack([np.zeros(5), np.full(5, 1.6), np.linspace(2, 40, 5)])
    for lanes, scores in (([lane + [np.inf, 0, 0]], [0.9]), ([lane], [np.nan])):
        with pytest.raises(MetricInputError, match="finite"):
            metric.update(golden["order"][0], lanes, scores)
