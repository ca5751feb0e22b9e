"""The three protocols: hand-checked small cases and parity with the official tools' outputs."""

import json
import math

import numpy as np
import pandas as pd
import pytest
from conftest import GOLDEN
from hypothesis import given, settings
from hypothesis import strategies as st

from roneld_eval.config import PaperMetricParams

from roneld_eval.thresholds import parse_thresholds
from roneld_eval.geometry import MapGeometry
from roneld_eval.lanes_io import parse_lines_txt
from roneld_eval.metrics.lane_iou_f1 import (
    category_table,
    match_frame,
    f_measure,
    sum_counts,
)
from roneld_eval.metrics.iou import match_lanes
from roneld_eval.metrics.paper import bottom_x, ego_lanes, ego_masks, side_ious
from roneld_eval.metrics.sweep import sweep_accuracy
from roneld_eval.benchmarks.tusimple.official import bench_frame, mean_scores
from roneld_eval.model import Lane


def vertical(x, top=300, bottom=590):
    return Lane.from_xy([x, x], [bottom, top])


# ---- official CULane ------------------------------------------------------------------------


def test_culane_frame_counts():
    gt = [vertical(300), vertical(800), vertical(1300)]
    pred = [vertical(805), vertical(300), vertical(1000), Lane(np.zeros((0, 2)))]
    result = match_frame(gt, pred)
    assert (result.n_gt, result.n_pred) == (3, 4)
    assert result.matched_iou[0] == 1.0
    assert result.matched_iou[1] == pytest.approx(25 / 35, abs=0.02)  # 5 px shift of a ~31 px band
    assert result.true_positives(0.5) == 2
    counts = sum_counts([result], [0.5, 0.8])
    assert counts.tp.tolist() == [2, 1] and counts.fp.tolist() == [2, 3] and counts.fn.tolist() == [1, 2]


def test_culane_empty_sides():
    assert sum_counts([match_frame([], [vertical(1)])], [0.5]).fp.tolist() == [1]
    assert sum_counts([match_frame([vertical(1)], [])], [0.5]).fn.tolist() == [1]
    # A ground-truth lane of one point still counts (IoU 0): FN.
    counts = sum_counts([match_frame([Lane([[5, 5]]), vertical(300)], [vertical(300)])], [0.5])
    assert (counts.tp[0], counts.fn[0]) == (1, 1)


def test_threshold_is_strict():
    gt, pred = [vertical(300)], [vertical(300)]
    result = match_frame(gt, pred)
    assert result.true_positives(0.999) == 1 and result.true_positives(1.0) == 0


def test_match_lanes_is_the_official_km():
    similarity = np.array([[0.9, 0.8], [0.85, 0.1]])
    assert match_lanes(similarity).tolist() == [1, 0]  # total 1.65 beats 1.0
    assert match_lanes(np.array([[0.5, 0.6, 0.1]])).tolist() == [1]
    assert match_lanes(np.array([[0.5], [0.6], [0.1]])).tolist() == [-1, 0, -1]
    assert match_lanes(np.zeros((0, 3))).tolist() == []
    # Within the 1e-2 tolerance the official KM keeps its first tight edge; scipy's exact
    # assignment would prefer 0.605 + 0.6 = 1.205 over 0.6 + 0.6 = 1.2.
    near_tie = np.array([[0.6, 0.605], [0.6, 0.0]])
    assert match_lanes(near_tie).tolist() == [1, 0]


def test_f_measure_like_the_official_output():
    assert f_measure(0, 2346, 0)[0] == 0 and math.isnan(f_measure(0, 2346, 0)[1]) and f_measure(0, 2346, 0)[2] == 0
    precision, recall, f1 = f_measure(77540, 27317, 27346)
    assert (round(precision, 6), round(recall, 6), round(f1, 6)) == (0.739483, 0.739279, 0.739381)


def test_category_table():
    results = {"a.jpg": match_frame([vertical(300)], [vertical(300)]),
               "b.jpg": match_frame([], [vertical(300)])}
    table = category_table(results, {"normal": frozenset({"a.jpg"}), "cross": frozenset({"b.jpg"})}, 0.5)
    assert table["category"].tolist() == ["normal", "cross", "all"]
    assert table[["tp", "fp", "fn"]].values.tolist() == [[1, 0, 0], [0, 1, 0], [1, 1, 0]]


def test_culane_parity_with_the_official_evaluator():
    golden = json.loads((GOLDEN / "culane_official.json").read_text())
    results = []
    for frame in golden["frames"]:
        gt = parse_lines_txt(frame["gt"], frame["frame"])
        pred = parse_lines_txt(frame["pred"], frame["frame"]) if frame["pred"] is not None else ()
        results.append(match_frame(gt, pred))
    thresholds = sorted(golden["results"], key=float)
    counts = sum_counts(results, [float(t) for t in thresholds])
    ours = {t: dict(tp=int(counts.tp[k]), fp=int(counts.fp[k]), fn=int(counts.fn[k])) for k, t in enumerate(thresholds)}
    assert ours == golden["results"]


# ---- official TuSimple ----------------------------------------------------------------------


def test_tusimple_hand_checked():
    rows = list(range(160, 720, 10))
    gt = [[500] * 56, [-2] * 10 + [800] * 46]
    exact = [[500] * 56, [-2] * 10 + [800] * 46]
    assert bench_frame(exact, gt, rows) == (1.0, 0.0, 0.0)
    # 20 px off a vertical lane is not below the 20 px threshold: no row of that lane matches
    # (nor does the other prediction), so accuracy (0 + 1) / 2, one FP of two, one FN of two.
    off = [[520] * 56, [-2] * 10 + [800] * 46]
    assert bench_frame(off, gt, rows) == (0.5, 0.5, 0.5)
    # 19 px off matches every row.
    assert bench_frame([[519] * 56, [-2] * 10 + [800] * 46], gt, rows) == (1.0, 0.0, 0.0)
    assert bench_frame(exact + [[1] * 56] * 3, gt, rows) == (0.0, 0.0, 1.0)  # more than gt + 2
    assert bench_frame(exact, gt, rows, run_time=201) == (0.0, 0.0, 1.0)
    assert bench_frame([], gt, rows) == (0.0, 0.0, 1.0)


def _bench_lane_by_lane(pred, gt, y_samples):
    """LaneEval.bench as lane.py writes it: line_accuracy of each prediction, one at a time."""
    from roneld_eval.metrics.point_accuracy import lane_threshold

    def line_accuracy(pred, gt, thresh):  # lane.py's own
        pred = np.where(pred >= 0, pred, -100)
        gt = np.where(gt >= 0, gt, -100)
        return np.sum(np.where(np.abs(pred - gt) < thresh, 1., 0.)) / len(gt)

    if len(gt) + 2 < len(pred):
        return 0.0, 0.0, 1.0
    y = np.array(y_samples, dtype=float)
    line_accs, fn, matched = [], 0.0, 0.0
    for x_gts in gt:
        gt_array = np.array(x_gts, dtype=float)
        threshold = lane_threshold(gt_array, y)
        accs = [line_accuracy(np.array(p, dtype=float), gt_array, threshold) for p in pred]
        max_acc = max(accs) if accs else 0.0
        fn, matched = (fn + 1, matched) if max_acc < 0.85 else (fn, matched + 1)
        line_accs.append(max_acc)
    fp = len(pred) - matched
    if len(gt) > 4 and fn > 0:
        fn -= 1
    total = sum(line_accs) - (min(line_accs) if len(gt) > 4 else 0)
    return (total / max(min(4.0, len(gt)), 1.0), fp / len(pred) if len(pred) > 0 else 0.0,
            fn / max(min(len(gt), 4.0), 1.0))


@settings(max_examples=300, deadline=None, derandomize=True)
@given(st.integers(1, 56), st.integers(0, 6), st.integers(0, 8), st.integers(0, 2**32 - 1))
def test_tusimple_frames_score_as_lane_by_lane(rows, lanes, predictions, seed):
    # Every prediction's row hits are counted at once: the same doubles as line_accuracy's sums.
    random = np.random.default_rng(seed)
    y_samples = list(range(720 - 10 * rows, 720, 10))
    centre = random.uniform(0, 1280, lanes)
    gt = [[float(c + random.normal(0, 30)) if random.random() > 0.2 else -2.0 for _ in y_samples] for c in centre]
    pred = [[float(x + random.choice([0.0, random.normal(0, 15), 19.5, 20.0])) if x >= 0 else -2.0 for x in lane]
            for lane in gt][:predictions]
    pred += [[float(v) for v in random.uniform(-5, 1280, rows)] for _ in range(max(0, predictions - len(pred)))]
    assert bench_frame(pred, gt, y_samples) == _bench_lane_by_lane(pred, gt, y_samples)


def test_tusimple_parity_with_the_official_script():
    golden = json.loads((GOLDEN / "tusimple_official.json").read_text())
    scores = []
    for pred, label, expected in zip(golden["predictions"], golden["labels"], golden["per_frame"]):
        score = bench_frame(pred["lanes"], label["lanes"], label["h_samples"], pred["run_time"])
        assert list(score) == expected
        scores.append(score)
    total = mean_scores(scores, len(golden["labels"]))
    assert (total.accuracy, total.fp, total.fn) == tuple(golden["official"][k] for k in ("Accuracy", "FP", "FN"))


# ---- the paper's protocol --------------------------------------------------------------------


def test_bottom_x_extends_the_two_lowest_points():
    lane = Lane([[100, 400], [200, 500], [300, 300]])
    assert bottom_x(lane, 589) == pytest.approx(200 + 89 * (200 - 100) / 100)


def test_ego_lanes_are_nearest_either_side():
    lanes = [vertical(100), vertical(700), vertical(900), vertical(1500), Lane([[820, 300]])]
    left, right = ego_lanes(lanes, 1640, 590, 0.5)
    assert left.xs[0] == 700 and right.xs[0] == 900
    left, right = ego_lanes([vertical(100), vertical(300)], 1640, 590, 0.5)
    assert left.xs[0] == 300 and right is None


def test_side_ious_and_missing_predictions():
    geometry = MapGeometry(1640, 590, 800, 288)
    params = PaperMetricParams()
    gt = ego_masks([vertical(600), vertical(1100)], geometry, params, 0.5)
    ious = side_ious(gt, [vertical(600), None], geometry, params)
    assert set(ious) == {"left", "right"} and ious["right"] == 0.0
    assert 0.4 < ious["left"] < 0.7  # a 16 px line inside a 30 px one: about 17/31


def test_sweep_counts_strictly_above_each_threshold():
    per_frame = pd.DataFrame({"frame": list("abcd"), "side": ["left"] * 4, "method": ["m"] * 4,
                              "iou": [0.3, 0.31, 0.5, 0.0]})
    table = sweep_accuracy(per_frame, parse_thresholds("0.30:0.50:0.01"))
    by_threshold = dict(zip(table["threshold"], table["n_tp"]))
    assert by_threshold["0.30"] == 2 and by_threshold["0.31"] == 1 and by_threshold["0.50"] == 0
    assert table["n_gt"].unique().tolist() == [4]
    assert table.loc[0, "accuracy"] == 0.5
