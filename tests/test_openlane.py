"""OpenLane 2D scored as its lane2d evaluator scores it (golden values from OpenDriveLab/OpenLane
8a0ce6b built unchanged: tests/golden/openlane/lane2d_evaluator.json), with and without category
matching, on its own example, an invented set and its quirks (uint8 and truncated categories,
a NaN IoU); and the command's errors."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from roneld_eval.benchmarks.openlane.score import MODES, _score_frames, score_openlane
from roneld_eval.metrics.lane_errors import diagnosis_settings
from roneld_eval.cli import main
from roneld_eval.benchmarks.openlane.reader import read_list

GOLDEN = Path(__file__).parent / "golden" / "openlane"
EXPECTED = json.loads((GOLDEN / "lane2d_evaluator.json").read_text())["sets"]
CASES = [(name, mode, threshold) for name, modes in EXPECTED.items() for mode, by_threshold in modes.items()
         for threshold in by_threshold]


def scored(name: str):
    root = GOLDEN / name
    return score_openlane(root / "annotations", {"m": root / "results"}, list_file=root / "test_list.txt",
                          iou="0.3,0.5", workers=1)


@pytest.mark.parametrize("name, mode, threshold", CASES)
def test_totals_equal_the_official_evaluator(name, mode, threshold):
    rows = {(row[1], row[2]): row for row in scored(name).rows.rows}
    expected = EXPECTED[name][mode][threshold]
    assert rows[(mode, f"{float(threshold):.2f}")][3:6] == (expected["tp"], expected["fp"], expected["fn"])


@pytest.mark.parametrize("name, mode, threshold",
                         [case for case in CASES if "frames" in EXPECTED[case[0]][case[1]][case[2]]])
def test_every_frame_equals_the_official_evaluator(name, mode, threshold):
    root = GOLDEN / name
    frames = EXPECTED[name][mode][threshold]["frames"]
    relpaths = read_list(root / "test_list.txt")
    assert sorted(relpaths) == sorted(frames)
    diagnosis = diagnosis_settings(True, None, None, (float(threshold),))
    for relpath in relpaths:
        counts = _score_frames(([relpath], root / "annotations", (root / "results",), 1920, 1280, 30, (mode,),
                                (float(threshold),), None))
        assert [int(v) for v in counts[0, 0, 0]] == frames[relpath], relpath
        # diagnosed, the frame's counts are the same, and its error types add up to them
        counts, diagnosed = _score_frames(([relpath], root / "annotations", (root / "results",), 1920, 1280, 30,
                                           (mode,), (float(threshold),), diagnosis))
        assert [int(v) for v in counts[0, 0, 0]] == frames[relpath], relpath
        tp, fp, fn = frames[relpath]
        assert sum(diagnosed.errors[0, 0, 0, :4]) == fp and sum(diagnosed.errors[0, 0, 0, 4:]) == fn


def test_the_command_writes_both_matchings(tmp_path):
    root = GOLDEN / "example"
    result = CliRunner().invoke(main, ["score", "openlane", "--labels", str(root / "annotations"), "--pred-root",
                                       f"ex={root / 'results'}", "--out", str(tmp_path / "out"), "--quiet"])
    assert result.exit_code == 0, result.output
    assert (tmp_path / "out" / "official.csv").read_text().splitlines() == [
        "method,matching,threshold,tp,fp,fn,precision,recall,f1",
        "ex,same category,0.30,8,4,2,0.6666666666666666,0.8,0.7272727272727272",
        "ex,any category,0.30,10,2,0,0.8333333333333334,1.0,0.9090909090909091"]


def _frame(tmp_path: Path, lanes: list[dict], name: str = "pred") -> Path:
    root = tmp_path / name
    (root / "seg").mkdir(parents=True)
    (root / "seg" / "a.json").write_text(json.dumps({"lane_lines": lanes}))
    return root


def test_a_lane_without_category_is_refused_unless_categories_are_ignored(tmp_path):
    truth = _frame(tmp_path, [{"category": 1, "uv": [[100, 110, 120], [900, 800, 700]]}], "gt")
    pred = _frame(tmp_path, [{"uv": [[100, 110, 120], [900, 800, 700]]}])
    runner = CliRunner()
    result = runner.invoke(main, ["score", "openlane", "--labels", str(truth), "--pred-root", str(pred)])
    assert result.exit_code == 2 and "lane 0 has no `category`" in result.output and "--any-category" in result.output
    result = runner.invoke(main, ["score", "openlane", "--labels", str(truth), "--pred-root", str(pred),
                                  "--any-category", "--quiet", "--out", str(tmp_path / "out")])
    assert result.exit_code == 0, result.output
    assert (tmp_path / "out" / "official.csv").read_text().splitlines()[1] == (
        "pred,any category,0.30,1,0,0,1.0,1.0,1.0")


@pytest.mark.parametrize("text, problem", [
    ("{not json", "not JSON"),
    (json.dumps({"lane_lines": [{"category": 1, "uv": [[1, 2, 3], [4, 5]]}]}), "a v for every u"),
    (json.dumps({"lane_lines": [{"category": 1, "uv": [[1, "x"], [4, 5]]}]}), "something other than numbers"),
    (json.dumps({"lane_lines": [{"category": "left", "uv": [[1, 2], [4, 5]]}]}), "`category` must be a number"),
    (json.dumps({"lane_lines": {}}), "`lane_lines` must be a list"),
])
def test_a_broken_prediction_file_is_one_line(tmp_path, text, problem):
    truth = _frame(tmp_path, [{"category": 1, "uv": [[100, 110, 120], [900, 800, 700]]}], "gt")
    pred = tmp_path / "pred"
    (pred / "seg").mkdir(parents=True)
    (pred / "seg" / "a.json").write_text(text)
    result = CliRunner().invoke(main, ["score", "openlane", "--labels", str(truth), "--pred-root", str(pred),
                                       "--quiet"])
    assert result.exit_code == 2
    assert result.output.startswith(f"error: {pred / 'seg' / 'a.json'}: ") and problem in result.output
    assert result.output.count("\n") == 1


def test_run_on_openlane_says_to_score_lane_files():
    result = CliRunner().invoke(main, ["run", "--dataset", "openlane", "--quiet"])
    assert result.exit_code == 2
    assert result.output == "error: OpenLane is scored from lane files only: `roneld-eval score openlane`\n"


def test_modes_are_the_evaluators_two():
    assert MODES == ("same category", "any category")


def test_roneld_eval_score_is_the_benchmarks_scorer_by_name():
    """`roneld_eval.score(NAME, ...)` runs the scorer of `score NAME` with its arguments."""
    import roneld_eval

    name = next(iter(EXPECTED))
    root = GOLDEN / name
    by_name = roneld_eval.score("openlane", labels=root / "annotations", pred_root={"m": root / "results"},
                                list_file=root / "test_list.txt", iou="0.3,0.5", workers=1)
    assert by_name.rows.rows == scored(name).rows.rows
    with pytest.raises(roneld_eval.ConfigError, match="unknown dataset 'nope'"):
        roneld_eval.score("nope")
