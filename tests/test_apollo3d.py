"""`score apollo3d` against Gen-LaneNet's evaluator (goldens in tests/golden/apollo3d, each with the
tool's commit and stack), its refusals, shards, several methods and the metric in memory."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from roneld_eval.benchmarks.apollo3d import official
from roneld_eval.benchmarks.apollo3d.official import frame_sweep
from roneld_eval.benchmarks.apollo3d.reader import prediction_of, records, truth_of
from roneld_eval.benchmarks.apollo3d.score import score_apollo3d
from roneld_eval.benchmarks.apollo3d.synth import synth_apollo3d
from roneld_eval.cli import main
from roneld_eval.metrics import lane3d_flow

GOLDEN = Path(__file__).parent / "golden" / "apollo3d"
NAMED = {"f": "F", "recall": "R", "precision": "P", "x_error_near": "x_error_close", "x_error_far": "x_error_far",
         "z_error_near": "z_error_close", "z_error_far": "z_error_far"}


def invoke(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


@pytest.fixture(scope="module", params=[0, 1])
def golden_set(request, tmp_path_factory):
    golden = json.loads((GOLDEN / f"synth_seed{request.param}.json").read_text())
    assert golden["set"]["command"].endswith(f"--clips 10 --frames 5 --seed {request.param}")
    out = tmp_path_factory.mktemp(f"apollo{request.param}")
    synth_apollo3d(out, clips=10, frames=5, seed=request.param)
    return out, golden


def _frames(root: Path):
    """Each prediction line's raw_file and its sweep per lane type, in the prediction file's order."""
    truths = {key: truth_of(record, root, number) for number, key, record in records(root / "test.json")}
    for number, key, record in records(root / "pred.json"):
        predicted = prediction_of(record, root, number)
        yield key, {kind: frame_sweep(predicted.lanes[kind], predicted.probabilities[kind], truths[key].lanes[kind],
                                      truths[key].visibility[kind]) for kind in official.LANE_TYPES}


def test_every_frame_at_every_threshold_is_the_evaluators_count_for_count(golden_set):
    root, golden = golden_set
    pytest.importorskip("ortools")
    compared = 0
    for (key, sweeps), theirs in zip(_frames(root), golden["frames"], strict=True):
        assert key == theirs["raw_file"]
        for kind, sweep in sweeps.items():
            assert sweep.counts[:, :4].tolist() == theirs[kind]["sweep"], (key, kind)
            assert [[list(pair) for pair in pairs] for pairs in sweep.pairs] == theirs[kind]["matching"], (key, kind)
            compared += 1
    assert compared == 100
    matched = sum(frame[kind]["sweep"][9][0] for frame in golden["frames"] for kind in official.LANE_TYPES)
    assert matched > 60  # enough recalled lanes at 0.5 to mean something


def test_the_chosen_thresholds_errors_are_the_evaluators_bit_for_bit(golden_set):
    root, golden = golden_set
    pytest.importorskip("ortools")
    best = official.THRESHOLDS.tolist().index(float(golden["max_F_prob_th"]))
    for (key, sweeps), theirs in zip(_frames(root), golden["frames"], strict=True):
        for kind, sweep in sweeps.items():
            assert sweep.counts[best, :4].tolist() == theirs[kind]["best"], (key, kind)
            assert sweep.errors[best].T.tolist() == theirs[kind]["errors"], (key, kind)


def test_the_numbers_and_the_printed_lines_are_the_evaluators(golden_set):
    root, golden = golden_set
    pytest.importorskip("ortools")
    score = score_apollo3d(root / "test.json", root / "pred.json", workers=1)
    assert score is not None
    for kind in official.LANE_TYPES:
        assert repr(score.value("pred", "ap", kind)) == golden["ap"][kind]
        assert repr(score.value("pred", "threshold", kind)) == golden["max_F_prob_th"]
        for column, theirs in NAMED.items():
            assert repr(score.value("pred", column, kind)) == golden["eval_stats_named"][f"{kind}_{theirs}"], column
    assert "\n".join(score.printed["pred"]) + "\n" == golden["printed"]


def test_the_command_prints_the_evaluators_lines_and_writes_the_tables(golden_set, tmp_path):
    root, golden = golden_set
    pytest.importorskip("ortools")
    result = invoke("score", "apollo3d", "--labels", root / "test.json", "--pred", root / "pred.json", "--out",
                    tmp_path / "out", "--workers", "2")
    assert result.exit_code == 0, result.output
    for line in golden["printed"].splitlines():
        assert f"  {line}\n" in result.output
    assert "chosen on the test set" in result.output
    official_csv = (tmp_path / "out" / "official.csv").read_text().splitlines()
    assert official_csv[0].startswith("method,lane_type,frames,threshold,recalled")
    assert len(official_csv) == 3 and len((tmp_path / "out" / "sweep.csv").read_text().splitlines()) == 1 + 2 * 19
    summary = (tmp_path / "out" / "summary.md").read_text()
    assert golden["printed"].splitlines()[1] in summary and "chosen on the test set" in summary


def test_without_ortools_every_matching_costs_what_the_evaluators_costs(golden_set, monkeypatch):
    root, golden = golden_set
    monkeypatch.setattr(lane3d_flow, "flow_solver", lambda: None)
    other = set()
    for (key, sweeps), theirs in zip(_frames(root), golden["frames"], strict=True):
        for kind, sweep in sweeps.items():
            for t, (mine, want) in enumerate(zip(sweep.pairs, theirs[kind]["matching"], strict=True)):
                assert sum(pair[2] for pair in mine) == sum(pair[2] for pair in want), (key, kind, t)
                counted = [list(pair) for pair in mine if pair[2] < official.MATCH_LIMIT]
                if counted == [pair for pair in want if pair[2] < official.MATCH_LIMIT]:
                    assert sweep.counts[t, :4].tolist() == theirs[kind]["sweep"][t]
                else:
                    other.add((key, kind))
    # the frames with several matchings of the least cost among lanes that match (a lane predicted twice, some 12%
    # of frames here); pairs of
    # cost 150, lanes that share no visible sample, tie everywhere but never count
    assert len(other) <= 15


def test_a_probability_of_exactly_a_threshold_passes_the_one_a_hair_below_it():
    assert official.THRESHOLDS[9] < 0.5 and 0.5 > official.THRESHOLDS[9]
    lane = np.column_stack([np.zeros(20), np.linspace(5, 90, 20), np.zeros(20)])
    sweep = frame_sweep([lane], [0.5], [lane], [np.ones(20)])
    kept = sweep.counts[:, 3].tolist()
    assert kept[9] == 1.0  # 0.5 > 0.49999999999999994
    assert kept[10] == 0.0


def test_several_prediction_files_are_several_methods_each_in_its_own_order(tmp_path):
    synth_apollo3d(tmp_path, clips=3, frames=3, seed=4)
    lines = (tmp_path / "pred.json").read_text().splitlines()
    (tmp_path / "reversed.json").write_text("\n".join(lines[::-1]) + "\n")
    both = score_apollo3d(tmp_path / "test.json", [tmp_path / "pred.json", f"other={tmp_path / 'reversed.json'}"],
                          workers=1)
    one = score_apollo3d(tmp_path / "test.json", tmp_path / "pred.json", workers=1)
    assert both.methods == ("pred", "other")
    for column in ("ap", "f", "recall", "threshold"):
        assert both.value("pred", column) == one.value("pred", column) == both.value("other", column)
    # the errors are averaged in each file's order: the same numbers to the last few bits
    assert both.value("other", "x_error_near") == pytest.approx(one.value("pred", "x_error_near"), rel=1e-12)


def test_shards_merge_into_the_unsharded_files_byte_for_byte(tmp_path):
    synth_apollo3d(tmp_path / "set", clips=5, frames=4, seed=2)
    labels, pred = tmp_path / "set" / "test.json", tmp_path / "set" / "pred.json"
    whole = invoke("score", "apollo3d", "--labels", labels, "--pred", pred, "--out", tmp_path / "whole", "--workers", 1)
    assert whole.exit_code == 0, whole.output
    for k in (1, 2, 3):
        part = invoke("score", "apollo3d", "--labels", labels, "--pred", pred, "--out", tmp_path / f"p{k}",
                      "--shard", f"{k}/3", "--workers", 1)
        assert part.exit_code == 0, part.output
    merged = invoke("merge", tmp_path / "p1", tmp_path / "p2", tmp_path / "p3", "--out", tmp_path / "merged")
    assert merged.exit_code == 0, merged.output
    for name in ("official.csv", "sweep.csv", "summary.md"):
        assert (tmp_path / "merged" / name).read_bytes() == (tmp_path / "whole" / name).read_bytes(), name
    pred.write_text(pred.read_text().replace('"laneLines_prob": [', '"laneLines_prob": [0.99, ', 0).replace(
        "0.9", "0.8", 1))  # an edited prediction file: the merge refuses
    again = invoke("merge", tmp_path / "p1", tmp_path / "p2", tmp_path / "p3", "--out", tmp_path / "again")
    assert again.exit_code != 0 and "Traceback" not in again.output


def _write(path: Path, records: list[dict]) -> Path:
    path.write_text("".join(json.dumps(record) + "\n" for record in records))
    return path


LANE = [[0.0, 5.0, 0.0], [0.1, 50.0, 0.0], [0.2, 90.0, 0.1]]
LABEL = {"raw_file": "images/00/0.jpg", "laneLines": [LANE], "laneLines_visibility": [[1, 1, 1]],
         "centerLines": [], "centerLines_visibility": []}
PRED = {"raw_file": "images/00/0.jpg", "laneLines": [LANE], "laneLines_prob": [0.9], "centerLines": [],
        "centerLines_prob": []}


@pytest.mark.parametrize("labels, preds, says", [
    ([LABEL, LABEL], [PRED], "labelled twice"),
    ([LABEL], [PRED, PRED], "predicted twice"),
    ([LABEL, {**LABEL, "raw_file": "images/00/1.jpg"}], [PRED], "no prediction for 1 of 2"),
    ([LABEL], [{**PRED, "raw_file": "images/09/0.jpg"}], "not in the labels"),
    ([LABEL], [{**PRED, "laneLines": [LANE[:1]]}], "at least 2 points where its probability is above 0.05"),
    ([LABEL], [{**PRED, "laneLines_prob": []}], "`laneLines_prob` must hold a probability for each of its 1 lanes"),
    ([LABEL], [{**PRED, "laneLines_prob": ["0.9"]}], "not a probability"),
    ([LABEL], [{**PRED, "laneLines": [[[0.0, 5.0, float("nan")], [0.0, 9.0, 0.0]]]}], "finite numbers"),
    ([{**LABEL, "laneLines_visibility": [[1, 1]]}], [PRED], "a number for each of its lane's 3 points"),
    ([LABEL], [{"raw_file": "images/00/0.jpg"}], "has no `laneLines`"),
    ([LABEL], [{**PRED, "laneLines": [[[0.0, 5.0, 1e300], [0.0, 90.0, -1e300]]]}],
     "pred.json: images/00/0.jpg: a lane lies so far off that its distance to another is beyond"),
    ([{"raw_file": "images/00/0.jpg"}], [PRED], "test.json:1: has no `laneLines`"),
    ([LABEL, {"raw_file": "images/00/1.jpg", "laneLines": [], "laneLines_visibility": []}],
     [PRED, {**PRED, "raw_file": "images/00/1.jpg"}], "test.json:2: has no `centerLines` where other lines have them"),
])
def test_bad_files_are_refused_in_one_line_naming_the_file(tmp_path, labels, preds, says):
    result = invoke("score", "apollo3d", "--labels", _write(tmp_path / "test.json", labels), "--pred",
                    _write(tmp_path / "pred.json", preds), "--workers", 1)
    assert result.exit_code != 0 and "Traceback" not in result.output
    assert says in result.output, result.output


def test_a_blank_line_and_mixed_centre_lines_are_refused_with_their_line(tmp_path):
    labels = _write(tmp_path / "test.json", [LABEL, {**LABEL, "raw_file": "images/00/1.jpg"}])
    blank = tmp_path / "blank.json"
    blank.write_text(json.dumps(PRED) + "\n\n" + json.dumps({**PRED, "raw_file": "images/00/1.jpg"}) + "\n")
    result = invoke("score", "apollo3d", "--labels", labels, "--pred", blank)
    assert result.exit_code != 0 and "blank.json:2: a blank line" in result.output
    mixed = _write(tmp_path / "mixed.json", [PRED, {"raw_file": "images/00/1.jpg", "laneLines": [],
                                                    "laneLines_prob": []}])
    result = invoke("score", "apollo3d", "--labels", labels, "--pred", mixed)
    assert result.exit_code != 0 and "mixed.json:2: has no `centerLines` where other lines have them" in result.output


def test_predictions_without_centre_lines_are_scored_on_lane_lines_with_a_warning(tmp_path):
    labels = _write(tmp_path / "test.json", [LABEL])
    pred = _write(tmp_path / "pred.json", [{"raw_file": "images/00/0.jpg", "laneLines": [LANE],
                                            "laneLines_prob": [0.9]}])
    result = invoke("score", "apollo3d", "--labels", labels, "--pred", pred)
    assert result.exit_code == 0, result.output
    assert "lane lines only" in result.output and "Laneline:  1.0  1.0" in result.output
    assert "Centerline" not in result.output.split("warning")[0]


def test_the_metric_in_memory_gives_what_the_command_writes(golden_set):
    import roneld_eval

    root, _ = golden_set
    metric = roneld_eval.metric("apollo3d", labels=root / "test.json")
    for number, key, record in records(root / "pred.json"):
        predicted = prediction_of(record, root, number)
        metric.update(key, list(predicted.lanes["laneline"]), list(predicted.probabilities["laneline"]),
                      center_lanes=list(predicted.lanes["centerline"]),
                      center_scores=list(predicted.probabilities["centerline"]))
    computed = metric.compute()
    score = score_apollo3d(root / "test.json", root / "pred.json", workers=1)
    assert computed["ap"] == score.value("pred", "ap") and computed["f"] == score.value("pred", "f")
    assert computed["centerline_ap"] == score.value("pred", "ap", "centerline")
    # label order, not the prediction file's: the same errors to the last bits of their sums
    assert computed["x_error_near"] == pytest.approx(score.value("pred", "x_error_near"), rel=1e-12)


def test_synth_is_deterministic(tmp_path):
    synth_apollo3d(tmp_path / "a", clips=2, frames=3, seed=9)
    synth_apollo3d(tmp_path / "b", clips=2, frames=3, seed=9)
    for name in ("test.json", "pred.json"):
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes()


def test_nothing_above_the_lowest_threshold_prints_what_the_evaluator_prints(tmp_path):
    """As the evaluator does on such a set (its run in tests/golden/apollo3d's stack): AP 0.5 from the
    curve's added ends, F 0, no error to average; a one-point lane below every threshold is never
    compared, so it is no error either."""
    labels = _write(tmp_path / "test.json", [LABEL, {**LABEL, "raw_file": "images/00/1.jpg"}])
    pred = _write(tmp_path / "pred.json", [{**PRED, "laneLines_prob": [0.05]},
                                           {**PRED, "raw_file": "images/00/1.jpg", "laneLines": [LANE, LANE[:1]],
                                            "laneLines_prob": [0.01, 0.04]}])
    score = score_apollo3d(labels, pred, workers=1)
    assert score.printed["pred"][1] == "Laneline:  0.5  0.0  nan  nan  nan  nan"
    assert score.value("pred", "threshold") == 0.05


def test_json_nested_too_deeply_is_one_line(tmp_path):
    labels = _write(tmp_path / "test.json", [LABEL])
    (tmp_path / "pred.json").write_text('{"raw_file": "x", "laneLines": ' + "[" * 100000 + "]" * 100000 + "}\n")
    result = invoke("score", "apollo3d", "--labels", labels, "--pred", tmp_path / "pred.json")
    assert result.exit_code != 0 and "pred.json:1: not an Apollo 3D line: nested too deeply" in result.output


def test_the_metric_in_memory_refuses_what_the_files_may_not_hold(golden_set):
    import roneld_eval
    from roneld_eval.in_memory import MetricInputError

    root, golden = golden_set
    metric = roneld_eval.metric("apollo3d", labels=root / "test.json")
    frame = golden["frames"][0]["raw_file"]
    lane = np.column_stack([np.zeros(5), np.linspace(5, 60, 5), np.zeros(5)])
    for lanes, scores, says in (([lane + [np.nan, 0, 0]], [0.9], "finite"), ([lane], [np.nan], "finite"),
                                ([lane], [[0.9]], "one probability for each")):
        with pytest.raises(MetricInputError, match=says):
            metric.update(frame, lanes, scores)
