"""The official tables a run counts frame by frame (a few sums per method and category) equal
the tables the metric functions give for the same records all at once: CULane's category table and TuSimple's
mean scores, bit for bit, in any order of methods and frames."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from hypothesis import given, settings
from hypothesis import strategies as st

from roneld_eval.benchmarks.culane.benchmark import BENCHMARK as CULANE, CulaneOfficial
from roneld_eval.benchmarks.tusimple.benchmark import BENCHMARK as TUSIMPLE, TusimpleOfficial
from roneld_eval.config import EvalConfig
from roneld_eval.metrics.lane_iou_f1 import FrameMatches, category_table
from roneld_eval.benchmarks.tusimple.official import mean_scores
from roneld_eval.model import Dataset

# -inf: unmatched; NaN: an IoU of nothing (above no threshold either way)
IOUS = st.one_of(st.just(float("-inf")), st.just(float("nan")), st.floats(0.0, 1.0))


@st.composite
def frame_results(draw) -> FrameMatches:
    matched = draw(st.lists(IOUS, max_size=5))
    return FrameMatches(len(matched), draw(st.integers(0, 6)), np.array(matched, np.float64))


@st.composite
def culane_runs(draw):
    frames = [f"driver_1/{k:05d}.jpg" for k in range(draw(st.integers(0, 12)))]
    methods = draw(st.lists(st.sampled_from(["baseline", "roneld", "mine"]), min_size=1, max_size=3, unique=True))
    records = {method: [(frame, CulaneOfficial(draw(frame_results()), draw(frame_results()))) for frame in frames]
               for method in methods}
    categories = {name: frozenset(draw(st.lists(st.sampled_from(frames), unique=True)) if frames else ())
                  # "all": a list may take the name of the row over every frame; both rows must stay right
                  for name in draw(st.lists(st.sampled_from(["normal", "night", "curve", "all"]), unique=True))}
    threshold = draw(st.sampled_from([0.3, 0.5, 0.75]))
    return records, categories, threshold


def culane_reference(records, categories, threshold) -> pd.DataFrame:
    """Each method's table from its records at once (as runs built it before tallies)."""
    tables = []
    for method, frames in records.items():
        table = category_table({relpath: record.all_lanes for relpath, record in frames}, categories, threshold)
        ego = category_table({relpath: record.ego for relpath, record in frames}, {}, threshold)
        ego["category"] = "ego"
        table = pd.concat([table, ego], ignore_index=True)
        table.insert(0, "method", method)
        tables.append(table)
    return pd.concat(tables, ignore_index=True)


@settings(max_examples=60, deadline=None)
@given(culane_runs())
def test_culane_tally_equals_the_category_tables(run):
    records, categories, threshold = run
    config = EvalConfig.preset("scnn-culane").with_overrides(**{"official.iou_threshold": threshold})
    dataset = Dataset(name="culane", root=Path("."), clips=(), image_width=1640, image_height=590,
                      categories=categories)
    tally = CULANE.tally(list(records), dataset, config)
    # Frame by frame, methods interleaved, as a run's clips arrive.
    for index in range(max(len(frames) for frames in records.values())):
        for method, frames in records.items():
            tally.add(method, *frames[index])
    expected = culane_reference(records, categories, threshold)
    pd.testing.assert_frame_equal(tally.table(), expected, check_exact=True)
    # Method by method, as the records were grouped: the order of adding changes nothing.
    by_method = CULANE.tally(list(records), dataset, config)
    for method, frames in records.items():
        for relpath, record in frames:
            by_method.add(method, relpath, record)
    pd.testing.assert_frame_equal(by_method.table(), expected, check_exact=True)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.floats(0, 1), st.floats(0, 1), st.floats(0, 1)), max_size=30),
       st.lists(st.sampled_from(["baseline", "roneld"]), min_size=1, max_size=2, unique=True))
def test_tusimple_tally_equals_the_mean_scores(scores, methods):
    config = EvalConfig.preset("scnn-tusimple")
    dataset = Dataset(name="tusimple", root=Path("."), clips=(), image_width=1280, image_height=720)
    tally = TUSIMPLE.tally(methods, dataset, config)
    for index, values in enumerate(scores):
        for method in methods:
            tally.add(method, f"clips/{index}/20.jpg", TusimpleOfficial(*values))
    table = tally.table()
    expected = mean_scores(scores, len(scores))
    for method in methods:
        row = table[table["method"] == method].iloc[0]
        got = (row.accuracy, row.fp, row.fn)
        want = (expected.accuracy, expected.fp, expected.fn)
        assert all((np.isnan(a) and np.isnan(b)) or a == b for a, b in zip(got, want))
    assert list(table["method"]) == list(methods)
