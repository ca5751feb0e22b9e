"""`roneld_eval.metric(name, ...)`: a benchmark's official metric fed lanes in memory gives the
numbers `score NAME` gives for the same lanes in files, whatever the order of the updates."""

from __future__ import annotations

import random
import shutil

import numpy as np
import pytest

import roneld_eval
from roneld_eval.benchmarks.culane.reader import labels_path
from roneld_eval.benchmarks.culane.synth import synth_culane
from roneld_eval.lanes_io import read_lines_txt


@pytest.fixture(scope="module")
def culane_set(tmp_path_factory):
    root = tmp_path_factory.mktemp("culane-metric")
    synth_culane(root / "set", clips=3, frames=5, seed=11, maps_format="lanes")
    data, pred = root / "set" / "data", root / "set" / "maps"
    metric = roneld_eval.metric("culane", data_root=data, iou="0.3:0.7:0.1")
    lanes = {frame: [lane.points for lane in read_lines_txt(labels_path(pred, frame))] for frame in metric.core.frames}
    return root, data, pred, lanes


def same(a: dict[str, float], b: dict[str, float]) -> bool:
    """The same names and the same bits (NaN, a ratio of no lanes, equal to NaN)."""
    return list(a) == list(b) and np.array_equal(np.array(list(a.values())), np.array(list(b.values())),
                                                 equal_nan=True)


def _scores_of(score) -> dict[str, float]:
    """`score culane`'s official rows as the metric names its numbers."""
    out = {}
    for _, category, label, _, _, _, precision, recall, f1 in score.official_rows.rows:
        prefix = "" if category == "all" else f"{category}/"
        percent = f"{round(float(label) * 100)}"
        out.update({f"{prefix}F1@{percent}": f1, f"{prefix}precision@{percent}": precision,
                    f"{prefix}recall@{percent}": recall})
    for row in score.summary_rows.rows:
        if "mF1" in score.summary_rows.columns:
            category = row[1]
            out[("" if category == "all" else f"{category}/") + "mF1"] = row[score.summary_rows.columns.index("mF1")]
    return out


def test_lanes_in_memory_score_as_score_culane_scores_their_files(culane_set):
    _, data, pred, lanes = culane_set
    expected = _scores_of(roneld_eval.score_culane(data, pred, iou="0.3:0.7:0.1"))
    metric = roneld_eval.metric("culane", data_root=data, iou="0.3:0.7:0.1")
    frames = list(lanes)
    random.Random(5).shuffle(frames)
    for frame in frames:
        metric.update(frame, lanes[frame])
    got = metric.compute()
    assert same(got, expected)
    assert {"F1@50", "precision@50", "recall@50", "mF1", "normal/F1@50"} <= set(got)
    assert 0 < got["F1@50"] < 1


def test_any_order_and_batches_give_the_same_bits(culane_set):
    _, data, _, lanes = culane_set
    results = []
    for seed in (1, 2):
        metric = roneld_eval.metric("culane", data_root=data, preset="clrnet")
        frames = list(lanes)
        random.Random(seed).shuffle(frames)
        metric.update_many(frames[:7], [lanes[f] for f in frames[:7]])
        for frame in frames[7:]:
            metric.update(frame, [np.asarray(points).tolist() for points in lanes[frame]])  # lists of pairs too
        results.append(metric.compute())
    assert same(results[0], results[1])
    assert {"F1@50", "F1@75", "mF1"} <= set(results[0])


def test_frames_never_updated_count_as_missing_prediction_files(culane_set, tmp_path):
    _, data, pred, lanes = culane_set
    kept = list(lanes)[::2]
    partial = tmp_path / "partial"
    for frame in kept:
        source = labels_path(pred, frame)
        target = labels_path(partial, frame)
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(source, target)
    expected = _scores_of(roneld_eval.score_culane(data, partial))
    metric = roneld_eval.metric("culane", data_root=data)
    for frame in kept:
        metric.update(frame, lanes[frame])
    assert same(metric.compute(), expected)


@pytest.mark.parametrize("frame, lanes, problem", [
    ("nowhere/00000.jpg", [], "is not a frame of this culane list"),
    (None, [], "is not a frame of this culane list"),
    ("FIRST", [[1.0, 2.0, 3.0]], "lane 0: points must be an (N, 2) array"),
    ("FIRST", [[[1.0, float("nan")], [2.0, 3.0]]], "lane 0: a coordinate is NaN or infinite"),
    ("FIRST", [[[1e30, 1.0], [2.0, 3.0]]], "lane 0: a coordinate lies more than 2^24 px"),
    ("FIRST", np.zeros((4, 2)), "lanes must be a sequence of (N, 2) point arrays"),
    ("FIRST", 5, "lanes must be a sequence of (N, 2) point arrays, got a int"),
    ("FIRST", {"a": [[1.0, 2.0]]}, "lanes must be a sequence of (N, 2) point arrays, got a dict"),
    ("FIRST", [[[1.0, 2.0], [3.0]]], "lane 0: points must be an (N, 2) array of numbers (rows of unequal length?)"),
    ("FIRST", [[["1", "2"], ["3", "4"]]], "lane 0: points must be numbers, got <U1 values"),
    ("FIRST", [np.array([[1 + 1j, 2.0], [3.0, 4.0]])], "lane 0: points must be numbers, got complex128"),
    ("FIRST", [np.ma.masked_array([[1.0, 2.0], [3.0, 4.0]], mask=[[1, 0], [0, 0]])], "masked points"),
    ("FIRST", [(x for x in [[1.0, 2.0]])], "got a generator"),
])
def test_a_refused_update_is_one_error_and_changes_nothing(culane_set, frame, lanes, problem):
    _, data, _, good = culane_set
    metric = roneld_eval.metric("culane", data_root=data)
    frames = list(good)
    metric.update(frames[1], good[frames[1]])
    before = metric.compute()
    with pytest.raises(roneld_eval.MetricInputError, match=".*" + __import__("re").escape(problem)):
        metric.update(frames[0] if frame == "FIRST" else frame, lanes)
    assert metric.frames_updated == 1 and same(metric.compute(), before)
    with pytest.raises(roneld_eval.MetricInputError, match="given twice"):
        metric.update(frames[1], good[frames[1]])
    with pytest.raises(roneld_eval.MetricInputError):  # one bad frame in a batch: none taken
        metric.update_many([frames[2], frames[0] if frame == "FIRST" else frame], [good[frames[2]], lanes])
    assert metric.frames_updated == 1 and same(metric.compute(), before)


def test_metrics_of_two_shares_merge_into_the_whole(culane_set):
    _, data, _, lanes = culane_set
    whole, first, second = (roneld_eval.metric("culane", data_root=data, iou="0.5:0.7:0.1") for _ in range(3))
    for k, frame in enumerate(lanes):
        whole.update(frame, lanes[frame])
        (first if k % 3 else second).update(frame, lanes[frame])
    first.merge(second.state())
    assert same(first.compute(), whole.compute())
    first.merge(second)  # a sampler's padding: the same frames with the same lanes, kept once
    assert same(first.compute(), whole.compute())
    frame = next(iter(lanes))
    other_lanes = roneld_eval.metric("culane", data_root=data, iou="0.5:0.7:0.1")
    other_lanes.update(frame, [points + 40.0 for points in lanes[frame]] + [np.array([[1.0, 580.0], [5.0, 300.0]])])
    with pytest.raises(roneld_eval.MetricInputError, match="updated in both metrics with different lanes"):
        first.merge(other_lanes)
    assert same(first.compute(), whole.compute())
    other = roneld_eval.metric("culane", data_root=data, iou="0.5")
    with pytest.raises(roneld_eval.MetricInputError, match="cannot merge"):
        other.merge(second)


def test_a_benchmark_without_an_in_memory_metric_says_so(monkeypatch):
    from roneld_eval.benchmarks import benchmark_for

    monkeypatch.delattr(type(benchmark_for("vil100")), "metric")
    with pytest.raises(roneld_eval.ConfigError, match="offers no in-memory metric yet"):
        roneld_eval.metric("vil100")


def test_float64_lanes_score_as_the_files_the_official_format_writes_of_them(culane_set, tmp_path):
    """Lanes of full float64 precision: what the C++ evaluator would read of them written as
    .lines.txt (float32, lanes_io.format_lines_txt) scores the same as the arrays."""
    from roneld_eval.lanes_io import format_lines_txt
    from roneld_eval.model import Lane

    _, data, _, lanes = culane_set
    rng = np.random.default_rng(3)
    moved = {frame: [points + rng.normal(0, 3, points.shape) for points in frame_lanes]
             for frame, frame_lanes in lanes.items()}
    files = tmp_path / "moved"
    metric = roneld_eval.metric("culane", data_root=data, iou="0.3:0.7:0.1")
    for frame, frame_lanes in moved.items():
        path = labels_path(files, frame)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(format_lines_txt([Lane(points) for points in frame_lanes]))
        metric.update(frame, frame_lanes)
    assert same(metric.compute(), _scores_of(roneld_eval.score_culane(data, files, iou="0.3:0.7:0.1")))


# ---- TuSimple -------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def tusimple_set(tmp_path_factory):
    from roneld_eval.benchmarks.tusimple.lane_format import read_tusimple_records
    from roneld_eval.benchmarks.tusimple.synth import synth_tusimple

    root = tmp_path_factory.mktemp("tusimple-metric")
    synth_tusimple(root / "set", clips=4, frames=3, seed=7, maps_format="lanes")
    labels, predictions = root / "set" / "data" / "test_label.json", root / "set" / "maps" / "predictions.json"
    records = {record["raw_file"]: record for _, record in read_tusimple_records(predictions, predictions=True)}
    return labels, predictions, records


def test_tusimple_lanes_in_memory_score_as_score_tusimple_scores_the_file(tusimple_set, tmp_path):
    labels, predictions, records = tusimple_set
    metric = roneld_eval.metric("tusimple", labels=labels)
    assert set(metric.core.frames) <= set(records)  # the detector's file holds every frame of a clip
    # the file in the label file's order: lane.py sums in the prediction file's order
    ordered = tmp_path / "ordered.json"
    lines = {__import__("json").loads(line)["raw_file"]: line for line in predictions.read_text().splitlines()}
    ordered.write_text("".join(lines[frame] + "\n" for frame in metric.core.frames))
    expected = roneld_eval.score_tusimple(labels, ordered)
    frames = list(metric.core.frames)
    random.Random(2).shuffle(frames)
    for frame in frames:
        record = records[frame]
        metric.update(frame, record["lanes"], h_samples=record["h_samples"], run_time=record["run_time"])
    got = metric.compute()
    assert got == {"Accuracy": expected.accuracy, "FP": expected.fp, "FN": expected.fn, "F1_ufld": expected.f1_ufld,
                   "F1_clrnet": expected.f1_clrnet}
    assert 0 < got["Accuracy"] < 1


def test_tusimple_refuses_what_lane_py_refuses(tusimple_set):
    labels, _, records = tusimple_set
    metric = roneld_eval.metric("tusimple", labels=labels)
    frame = metric.core.frames[0]
    rows = len(records[frame]["h_samples"])
    with pytest.raises(roneld_eval.MetricInputError, match=f"lane 0: needs one x per h_samples row \\({rows}\\)"):
        metric.update(frame, [[1.0, 2.0]])
    with pytest.raises(roneld_eval.MetricInputError, match="an x that is not a finite lane coordinate"):
        metric.update(frame, [[float("inf")] * rows])
    metric.update(frame, records[frame]["lanes"])
    with pytest.raises(roneld_eval.MetricInputError, match=f"no lanes given for {len(metric.core.frames) - 1} of"):
        metric.compute()  # lane.py stops where a labelled frame has no prediction


# ---- every benchmark with an in-memory metric: its tables are score NAME's --------------------------


def test_culane_tables_are_score_culanes_files(culane_set):
    _, data, pred, lanes = culane_set
    score = roneld_eval.score("culane", data, {"-": pred}, preset="clrnet")
    metric = roneld_eval.metric("culane", data_root=data, preset="clrnet")
    metric.update_many(list(lanes), list(lanes.values()))
    tables = metric.tables()
    assert tables["official"].to_csv() == score.official_rows.to_csv()
    assert tables["summary"].to_csv() == score.summary_rows.to_csv()


def test_tusimple_table_is_score_tusimples_file(tusimple_set, tmp_path):
    labels, predictions, records = tusimple_set
    metric = roneld_eval.metric("tusimple", labels=labels)
    ordered = tmp_path / "-.json"
    ordered.write_text("".join(__import__("json").dumps(records[frame]) + "\n" for frame in metric.core.frames))
    roneld_eval.score("tusimple", labels, ordered, out=tmp_path / "out")
    for frame in metric.core.frames:
        metric.update(frame, records[frame]["lanes"], run_time=records[frame]["run_time"])
    assert metric.tables()["official"].to_csv() == (tmp_path / "out" / "official.csv").read_text()


@pytest.fixture(scope="module")
def openlane_set(tmp_path_factory):
    from roneld_eval.benchmarks.openlane.reader import json_path, read_lanes
    from roneld_eval.benchmarks.openlane.synth import synth_openlane

    root = tmp_path_factory.mktemp("openlane-metric")
    synth_openlane(root / "set", clips=3, frames=3, seed=4)
    labels, predictions = root / "set" / "labels", root / "set" / "predictions"
    metric = roneld_eval.metric("openlane", labels=labels)
    lanes = {frame: read_lanes(json_path(predictions, frame)) for frame in metric.core.frames}
    return labels, predictions, lanes


def test_openlane_lanes_in_memory_score_as_score_openlane_scores_their_files(openlane_set, tmp_path):
    labels, predictions, lanes = openlane_set
    score = roneld_eval.score("openlane", labels, {"-": predictions}, iou="0.3,0.5", out=tmp_path / "out")
    metric = roneld_eval.metric("openlane", labels=labels, iou="0.3,0.5")
    frames = list(lanes)
    random.Random(4).shuffle(frames)
    for frame in frames[1:]:  # the first never updated: no lanes, as a missing file
        metric.update(frame, [lane.points for lane in lanes[frame].lanes], categories=lanes[frame].categories)
    missing_first = tmp_path / "missing-first"
    shutil.copytree(predictions, missing_first)
    (missing_first / (frames[0].rsplit(".", 1)[0] + ".json")).unlink()
    expected = roneld_eval.score("openlane", labels, {"-": missing_first}, iou="0.3,0.5")
    assert metric.tables()["official"].to_csv() == expected.rows.to_csv()
    metric.update(frames[0], [lane.points for lane in lanes[frames[0]].lanes], categories=lanes[frames[0]].categories)
    assert metric.tables()["official"].to_csv() == score.rows.to_csv()
    got = metric.compute()
    assert {"F1@30", "F1@50", "F1@30/any-category", "precision@50/any-category"} <= set(got)
    assert got["F1@30/any-category"] >= got["F1@30"] > 0


def test_openlane_needs_categories_to_match_within_them(openlane_set):
    labels, _, lanes = openlane_set
    frame, frame_lanes = next(iter(lanes.items()))
    metric = roneld_eval.metric("openlane", labels=labels)
    with pytest.raises(roneld_eval.MetricInputError, match="has no `category`"):
        metric.update(frame, [lane.points for lane in frame_lanes.lanes])
    any_category = roneld_eval.metric("openlane", labels=labels, modes=("any category",))
    any_category.update(frame, [lane.points for lane in frame_lanes.lanes])
    assert set(any_category.compute()) == {"F1@30/any-category", "precision@30/any-category",
                                           "recall@30/any-category"}


def test_curvelanes_lanes_in_memory_score_as_score_curvelanes_scores_their_files(tmp_path):
    from roneld_eval.benchmarks.curvelanes.reader import lanes_path, read_frame
    from roneld_eval.benchmarks.curvelanes.synth import synth_curvelanes

    synth_curvelanes(tmp_path / "set", clips=6, frames=1, seed=8)
    labels, predictions, images = (tmp_path / "set" / part for part in ("labels", "predictions", "images"))
    options = dict(labels=labels, image_root=images, score_threshold=0.5, best_of=(0.3, 0.6, 0.8))
    score = roneld_eval.score("curvelanes", labels, {"-": predictions}, images, score_threshold=0.5,
                              best_of=(0.3, 0.6, 0.8))
    metric = roneld_eval.metric("curvelanes", **options)
    frames = list(metric.core.frames)
    random.Random(1).shuffle(frames)
    for frame in frames:
        read = read_frame(lanes_path(predictions, frame), True)
        metric.update(frame, [np.array(lane) for lane in read.lanes],
                      None if None in read.scores else list(read.scores))
    assert metric.tables()["official"].to_csv() == score.rows.to_csv()
    got = metric.compute()
    assert {"F1", "precision", "recall", "best/F1", "best/score_threshold"} <= set(got)
    assert got["best/F1"] >= got["F1"] > 0


def test_the_readmes_training_loop_runs_as_written(culane_set):
    import re

    from conftest import REPO

    _, data, _, lanes = culane_set
    readme = (REPO / "README.md").read_text(encoding="utf-8")
    block = next(b for b in re.findall(r"^```python\n(.*?)^```", readme, flags=re.S | re.M)
                 if "roneld_eval.metric(" in b)
    frames = list(lanes)
    names = {"roneld_eval": roneld_eval,
             "validation": [(frames[k:k + 4], [lanes[f] for f in frames[k:k + 4]]) for k in range(0, len(frames), 4)]}
    exec(compile(block.replace("/data/CULane", str(data)), "README.md", "exec"), names)
    assert {"F1@50", "F1@75", "mF1"} <= set(names["scores"]) and 0 < names["scores"]["F1@50"] <= 1


def test_llamas_lanes_in_memory_score_as_score_llamas_scores_their_files(tmp_path):
    from roneld_eval.benchmarks.llamas.reader import prediction_path
    from roneld_eval.benchmarks.llamas.synth import synth_llamas

    result = synth_llamas(tmp_path / "set", clips=2, frames=4, seed=6)
    labels, predictions = result.data_root, result.maps_root
    score = roneld_eval.score("llamas", labels, {"-": predictions})
    metric = roneld_eval.metric("llamas", labels=labels)
    frames = list(metric.core.frames)
    random.Random(7).shuffle(frames)
    for frame in frames:
        metric.update(frame, [lane.points for lane in read_lines_txt(prediction_path(predictions, frame))])
    assert metric.tables()["official"].to_csv() == score.rows.to_csv()
    got = metric.compute()
    assert got["mF1"] == score.mf1("-") and got["F1@50"] == score.f1("-", "0.50") > 0
    assert {"F1@50", "F1@75", "mF1", "precision@50", "recall@75"} <= set(got)


@pytest.fixture(scope="module")
def vil100_set(tmp_path_factory):
    from roneld_eval.benchmarks.vil100.synth import synth_vil100

    root = tmp_path_factory.mktemp("vil100-metric")
    synth_vil100(root / "set", clips=3, frames=6, seed=3, maps_format="lanes")
    labels, sizes, predictions = root / "set" / "data" / "anno_txt", root / "set" / "data" / "sizes.json", \
        root / "set" / "maps"
    return labels, sizes, predictions


def test_vil100_lanes_in_memory_score_as_score_vil100_scores_their_files(vil100_set, tmp_path):
    from roneld_eval.benchmarks.vil100.reader import labels_path

    labels, sizes, predictions = vil100_set
    score = roneld_eval.score("vil100", labels, {"-": predictions}, sizes_file=sizes, iou="0.5,0.8",
                              out=tmp_path / "out")
    metric = roneld_eval.metric("vil100", labels=labels, sizes_file=sizes, iou="0.5,0.8")
    frames = list(metric.core.frames)
    random.Random(3).shuffle(frames)  # video order is the metric's business, not the caller's
    for frame in frames:
        metric.update(frame, [lane.points for lane in read_lines_txt(labels_path(predictions, frame))])
    tables = metric.tables()
    for name, file in (("official", "official.csv"), ("temporal", "temporal.csv"), ("acc", "acc.csv"),
                       ("summary", "summary.csv")):
        assert tables[name].to_csv() == (tmp_path / "out" / file).read_text(encoding="utf-8"), name
    got = metric.compute()
    every = next(row for row in score.rows.rows if row[1] == "all" and row[2] == "0.50")
    assert got["F1@50"] == every[8] and got["mIoU"] == every[9]
    assert {"F1@50", "F1@80", "mIoU", "Rs@50", "Rj@50", "Rm@80", "Acc", "FP", "FN"} <= set(got)
    assert any(key.startswith("curved-road/") or key.startswith("crowded/") for key in got)
    assert 0 < got["F1@50"] < 1 and abs(got["Rs@50"] + got["Rj@50"] + got["Rm@50"] - 1) < 1e-9


def test_vil100_frames_never_updated_count_as_missing_files(vil100_set, tmp_path):
    from roneld_eval.benchmarks.vil100.reader import labels_path

    labels, sizes, predictions = vil100_set
    metric = roneld_eval.metric("vil100", labels=labels, sizes_file=sizes, iou="0.5")
    kept = shutil.copytree(predictions, tmp_path / "kept")
    for k, frame in enumerate(metric.core.frames):
        if k % 3 == 1:
            labels_path(kept, frame).unlink()
        else:
            metric.update(frame, [lane.points for lane in read_lines_txt(labels_path(predictions, frame))])
    roneld_eval.score("vil100", labels, {"-": kept}, sizes_file=sizes, iou="0.5", out=tmp_path / "out")
    assert metric.tables()["temporal"].to_csv() == (tmp_path / "out" / "temporal.csv").read_text(encoding="utf-8")
    assert metric.tables()["official"].to_csv() == (tmp_path / "out" / "official.csv").read_text(encoding="utf-8")


def _epochs_without_labels(metric, update, labels, tmp_path) -> tuple[dict, dict]:
    """A first epoch, then the labels taken away and a second: the truth kept from the first."""
    update(metric)
    first = metric.compute()
    labels.rename(tmp_path / "labels-away")
    try:
        metric.reset()
        update(metric)
        return first, metric.compute()
    finally:
        (tmp_path / "labels-away").rename(labels)


def test_the_second_epoch_reads_no_label(culane_set, vil100_set, openlane_set, tmp_path):
    from roneld_eval.benchmarks.vil100.reader import labels_path as vil100_path

    _, data, _, lanes = culane_set
    culane = roneld_eval.metric("culane", data_root=data, iou="0.5")
    first, second = _epochs_without_labels(
        culane, lambda m: m.update_many(list(lanes), list(lanes.values())), data, tmp_path)
    assert same(first, second) and len(culane.core.truth) == len(lanes)

    labels, sizes, predictions = vil100_set
    vil100 = roneld_eval.metric("vil100", labels=labels, sizes_file=sizes)
    found = {f: [lane.points for lane in read_lines_txt(vil100_path(predictions, f))] for f in vil100.core.frames}
    first, second = _epochs_without_labels(
        vil100, lambda m: m.update_many(list(found), list(found.values())), labels, tmp_path)
    assert same(first, second) and first["F1@50"] > 0

    labels, _, read = openlane_set
    openlane = roneld_eval.metric("openlane", labels=labels)
    first, second = _epochs_without_labels(openlane, lambda m: [
        m.update(f, [lane.points for lane in read[f].lanes], categories=read[f].categories) for f in read],
        labels, tmp_path)
    assert same(first, second) and first["F1@30"] > 0


def test_options_it_does_not_take_are_one_line_listing_those_it_does(culane_set):
    _, data, _, _ = culane_set
    with pytest.raises(roneld_eval.ConfigError, match=r"unknown option iou_threshold; it takes data_root, list_file, "
                                                      r"iou, preset, width \(required: data_root\)"):
        roneld_eval.metric("culane", data_root=data, iou_threshold=0.5)
    with pytest.raises(roneld_eval.ConfigError, match="missing data_root"):
        roneld_eval.metric("culane")
    with pytest.raises(roneld_eval.ConfigError, match="matching must be among"):
        roneld_eval.metric("openlane", labels=data, modes="any category")
    with pytest.raises(roneld_eval.MetricInputError, match="offers no key names 'clrnet' \\(offered: clrernet\\)"):
        roneld_eval.metric("culane", data_root=data).compute("clrnet")


def test_a_frame_named_with_the_lists_leading_slash_is_that_frame(culane_set):
    _, data, _, lanes = culane_set
    metric = roneld_eval.metric("culane", data_root=data)
    frame = list(lanes)[0]
    metric.update("/" + frame, lanes[frame])
    with pytest.raises(roneld_eval.MetricInputError, match="given twice"):
        metric.update(frame, lanes[frame])


def test_curvelanes_best_of_must_be_a_sequence(tmp_path):
    from roneld_eval.benchmarks.curvelanes.synth import synth_curvelanes

    synth_curvelanes(tmp_path / "set", clips=2, frames=1, seed=8)
    labels, images = tmp_path / "set" / "labels", tmp_path / "set" / "images"
    with pytest.raises(roneld_eval.ConfigError, match="best_of must be a sequence of score thresholds, got a gen"):
        roneld_eval.metric("curvelanes", labels=labels, image_root=images, best_of=(t for t in (0.1, 0.5)))
    assert roneld_eval.metric("curvelanes", labels=labels, image_root=images, best_of=[0.1, 0.5]).core.best_of == (
        0.1, 0.5)


def test_tusimple_run_time_must_be_a_number_as_score_tusimple_says(tusimple_set):
    labels = tusimple_set[0]
    metric = roneld_eval.metric("tusimple", labels=labels)
    frame = metric.core.frames[0]
    rows = len(metric.core.labels[frame]["h_samples"])
    with pytest.raises(roneld_eval.MetricInputError, match="run_time must be a number of milliseconds, got '50'"):
        metric.update(frame, [[-2.0] * rows], run_time="50")
    metric.update(frame, [[-2.0] * rows], run_time=50)


def test_metrics_of_one_folder_named_differently_merge(culane_set):
    from pathlib import Path

    _, data, _, lanes = culane_set
    frames = list(lanes)
    one = roneld_eval.metric("culane", data_root=str(data))
    other = roneld_eval.metric("culane", data_root=Path(str(data) + "/"))
    one.update(frames[0], lanes[frames[0]])
    other.update(frames[1], lanes[frames[1]])
    one.merge(other.state())
    assert one.frames_updated == 2
    with pytest.raises(roneld_eval.MetricInputError, match="cannot merge"):
        one.merge(roneld_eval.metric("culane", data_root=data, iou="0.3"))
