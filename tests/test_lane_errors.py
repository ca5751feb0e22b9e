"""Lane error types (metrics.lane_errors): the kernel against its plain twin, the sums against the
official FP and FN, and small frames worked by hand."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from roneld_eval.metrics import _kernels as K
from roneld_eval.metrics.iou import KM_TOLERANCE, match_lanes
from roneld_eval.metrics.lane_errors import ERROR_TYPES, category_iou, classify, delta_f1, frame_errors

LIMITS = np.array([0.1, 0.3, 0.5, 0.5000001, 0.75, 0.9])


@st.composite
def similarities(draw):
    rows, columns = draw(st.integers(0, 6)), draw(st.integers(0, 6))
    values = st.sampled_from([0.0, 0.05, 0.1, 0.3, 0.5, 0.5, 0.75, 0.9, 1.0, np.nan]) | st.floats(0, 1)
    matrix = np.array(draw(st.lists(values, min_size=rows * columns, max_size=rows * columns)), np.float64)
    truth = draw(st.lists(st.integers(0, 2), min_size=rows, max_size=rows))
    predicted = draw(st.lists(st.integers(0, 2), min_size=columns, max_size=columns))
    same = np.equal.outer(np.array(truth, np.int64), np.array(predicted, np.int64)).reshape(rows, columns)
    return matrix.reshape(rows, columns), draw(st.sampled_from([0.0, 0.1, 0.3, 0.5])), same


def counted(preds: list[str], truth: list[str]) -> list[int]:
    return [(preds if side == "fp" else truth).count(kind) for side, kind in ERROR_TYPES]


@settings(max_examples=500, deadline=None, derandomize=True)
@given(similarities())
def test_the_kernel_counts_what_classify_names(case):
    raw, loc_iou, same = case
    for matrix, other in ((raw, None), category_iou(raw, same)):  # any category, then within categories
        errors = frame_errors(matrix, LIMITS, loc_iou, other_iou=other)
        rows, columns = np.arange(matrix.shape[0]), np.arange(matrix.shape[1])
        match = K.matched_columns(matrix, rows, columns, KM_TOLERANCE)
        np.testing.assert_array_equal(match, match_lanes(matrix) if matrix.size else np.full(matrix.shape[0], -1))
        np.testing.assert_array_equal(K.matched_columns.py_func(matrix, rows, columns, KM_TOLERANCE), match)
        twin = K.lane_error_counts.py_func(matrix, match, np.full(matrix.shape[1], -np.inf) if other is None
                                           else other, LIMITS, loc_iou)
        np.testing.assert_array_equal(errors.counts, twin)
        np.testing.assert_array_equal(errors.matched_iou, K.matched_ious(matrix, rows, columns, KM_TOLERANCE))
        for t, limit in enumerate(LIMITS):
            preds, truth = classify(matrix, float(limit), loc_iou, other_iou=other)
            assert errors.counts[t].tolist() == counted(preds, truth)
            tp = int(np.count_nonzero(errors.matched_iou > limit))
            # each side adds up to the official FP and FN, and Loc comes in pairs
            assert preds.count("TP") == truth.count("TP") == tp
            assert sum(errors.counts[t, :4]) == matrix.shape[1] - tp
            assert sum(errors.counts[t, 4:]) == matrix.shape[0] - tp
            assert errors.counts[t, 0] == errors.counts[t, 4]
            assert other is not None or errors.counts[t, 2] == 0


def test_a_frame_by_hand():
    # ground truth 0 found well by prediction 0 and again by 1 (a duplicate); ground truth 1 found
    # off by prediction 2 (0.3) and worse by 3 (0.2); ground truth 2 missed; prediction 4 on nothing
    similarity = np.array([[0.8, 0.6, 0.0, 0.0, 0.0],
                           [0.0, 0.0, 0.3, 0.2, 0.05],
                           [0.0, 0.0, 0.0, 0.0, 0.0]])
    preds, truth = classify(similarity, 0.5, 0.1)
    assert preds == ["TP", "Dupe", "Loc", "Dupe", "Bkg"]
    assert truth == ["TP", "Loc", "Miss"]
    assert frame_errors(similarity, np.array([0.5]), 0.1).counts.tolist() == [[1, 2, 0, 1, 1, 1]]
    # at IoU 0.25 prediction 2 is the match of ground truth 1; prediction 3 its duplicate
    assert classify(similarity, 0.25, 0.1) == (["TP", "Dupe", "TP", "Dupe", "Bkg"], ["TP", "TP", "Miss"])
    # at 0.85 the pair of 0.8 is no longer a true positive: prediction 0 is Loc, 1 its duplicate
    assert classify(similarity, 0.85, 0.1)[0][:2] == ["Loc", "Dupe"]


def test_a_lane_of_another_category_makes_a_category_error():
    # prediction 0 lies on lane 0 (IoU 0.8) but is of another category; prediction 1 is lane 1's
    similarity = np.array([[0.8, 0.0], [0.0, 0.7]])
    masked, other = category_iou(similarity, np.array([[False, False], [False, True]]))
    assert masked.tolist() == [[0.0, 0.0], [0.0, 0.7]] and other.tolist() == [0.8, 0.0]
    assert classify(masked, 0.5, 0.1, other_iou=other) == (["Cat", "TP"], ["Miss", "TP"])
    assert frame_errors(masked, np.array([0.5, 0.9]), 0.1, other_iou=other).counts.tolist() == [
        [0, 0, 1, 0, 0, 1], [1, 0, 0, 1, 1, 1]]  # at 0.9: 0.8 is no category error, 0.7 a Loc pair


def test_no_ground_truth_makes_every_prediction_background():
    errors = frame_errors(np.zeros((0, 3)), np.array([0.5]), 0.1)
    assert errors.counts.tolist() == [[0, 0, 0, 3, 0, 0]]
    assert frame_errors(np.zeros((2, 0)), np.array([0.5]), 0.1).counts.tolist() == [[0, 0, 0, 0, 0, 2]]


@pytest.mark.parametrize("tp, fp, fn, counts, expected", [
    (8, 4, 4, [2, 1, 0, 1, 2, 2], [2 * 10 / (2 * 10 + 2 + 2) - 2 * 8 / 24, 2 * 8 / (16 + 3 + 4) - 2 * 8 / 24, 0.0,
                                   2 * 8 / (16 + 3 + 4) - 2 * 8 / 24, 2 * 10 / 24 - 2 * 8 / 24,
                                   2 * 8 / (16 + 4 + 2) - 2 * 8 / 24]),
])
def test_delta_f1_fixes_one_type_at_a_time(tp, fp, fn, counts, expected):
    assert delta_f1(tp, fp, fn, counts) == pytest.approx(expected)
