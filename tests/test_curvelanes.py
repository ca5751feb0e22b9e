"""CurveLanes scored as CondLaneNet's lane_metric.py scores it (golden values from it run unchanged,
aliyun/conditional-lane-detection c57b242: tests/golden/curvelanes/lane_metric.json), its inputs and
the command's errors."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest
from click.testing import CliRunner

from roneld_eval.benchmarks.curvelanes.score import _score_frames, score_curvelanes
from roneld_eval.cli import main
from roneld_eval.benchmarks.curvelanes.reader import read_list

GOLDEN = Path(__file__).parent / "golden" / "curvelanes"
EXPECTED = json.loads((GOLDEN / "lane_metric.json").read_text())
THRESHOLDS = [float(t) for t in EXPECTED["thresholds"]]


@pytest.fixture(scope="module")
def images(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("curvelanes-images")
    for name, (width, height) in EXPECTED["sizes"].items():
        (root / name).parent.mkdir(parents=True, exist_ok=True)
        cv2.imwrite(str(root / f"{name}.jpg"), np.zeros((height, width), np.uint8))
    return root


def test_every_image_equals_the_metric(images):
    for relpath in read_list(GOLDEN / "list.txt"):
        counts = _score_frames(([relpath], GOLDEN / "labels", images, (GOLDEN / "pred",), THRESHOLDS, None))
        for t, threshold in enumerate(EXPECTED["thresholds"]):
            assert [int(v) for v in counts[0, t]] == EXPECTED["thresholds"][threshold]["frames"][relpath], relpath


def test_f1_at_a_threshold_and_the_best_of_a_list_equal_the_metrics_summary(images):
    score = score_curvelanes(GOLDEN / "labels", {"m": GOLDEN / "pred"}, images, list_file=GOLDEN / "list.txt",
                             best_of=THRESHOLDS[1:], workers=1)
    fixed, best = score.rows.rows
    summary = EXPECTED["thresholds"]["0.0"]["summary"]
    assert fixed[2] == "fixed" and fixed[4:9] == (summary["pr_num"], summary["gt_num"], summary["precision"],
                                                  summary["recall"], summary["f1_measure"])
    f1s = {threshold: EXPECTED["thresholds"][threshold]["summary"]["f1_measure"] for threshold in ("0.3", "0.5", "0.7")}
    chosen = max(f1s, key=lambda threshold: f1s[threshold])
    assert best[2] == "best on the test set" and best[1] == float(chosen) and best[8] == f1s[chosen]


def test_the_command_writes_official_csv(images, tmp_path):
    result = CliRunner().invoke(main, ["score", "curvelanes", "--labels", str(GOLDEN / "labels"), "--pred-root",
                                       f"m={GOLDEN / 'pred'}", "--image-root", str(images), "--best-of", "0.3,0.5",
                                       "--out", str(tmp_path / "out"), "--quiet"])
    assert result.exit_code == 0, result.output
    lines = (tmp_path / "out" / "official.csv").read_text().splitlines()
    assert lines[0] == "method,score_threshold,chosen,hits,predicted,truth,precision,recall,f1"
    assert lines[1].startswith("m,0.0,fixed,") and lines[2].startswith("m,0.3,best on the test set,")


def test_a_lane_with_a_repeated_point_is_refused_with_its_file(images, tmp_path):
    name = next(iter(EXPECTED["sizes"]))
    pred = tmp_path / "pred"
    (pred / name).parent.mkdir(parents=True)
    (pred / f"{name}.lines.json").write_text(json.dumps({"Lines": [[{"x": 5, "y": 9}, {"x": 5, "y": 9}]]}))
    result = CliRunner().invoke(main, ["score", "curvelanes", "--labels", str(GOLDEN / "labels"), "--pred-root",
                                       str(pred), "--image-root", str(images), "--quiet"])
    assert result.exit_code == 2
    assert result.output.startswith(f"error: {pred / name}.lines.json: lane 0 has two equal consecutive points")


def test_a_missing_image_is_one_line(tmp_path):
    result = CliRunner().invoke(main, ["score", "curvelanes", "--labels", str(GOLDEN / "labels"), "--pred-root",
                                       str(GOLDEN / "pred"), "--image-root", str(tmp_path), "--quiet"])
    assert result.exit_code == 2 and "image not found (needed for its size)" in result.output
    assert result.output.count("\n") == 1


def test_by_default_the_best_of_vegas_list_is_given_beside_the_fixed_threshold(images, tmp_path):
    from roneld_eval.benchmarks.curvelanes.score import VEGA_THRESHOLDS, score_curvelanes

    command = ["score", "curvelanes", "--labels", str(GOLDEN / "labels"), "--pred-root", f"m={GOLDEN / 'pred'}",
               "--image-root", str(images), "--quiet"]
    result = CliRunner().invoke(main, [*command, "--out", str(tmp_path / "out")])
    assert result.exit_code == 0, result.output
    lines = (tmp_path / "out" / "official.csv").read_text().splitlines()
    best = score_curvelanes(GOLDEN / "labels", {"m": GOLDEN / "pred"}, images, best_of=VEGA_THRESHOLDS, workers=1)
    assert lines[1:] == best.rows.to_csv().splitlines()[1:] and ",best on the test set," in lines[2]
    assert float(lines[2].split(",")[1]) in VEGA_THRESHOLDS
    result = CliRunner().invoke(main, [*command, "--best-of", "none", "--out", str(tmp_path / "fixed")])
    assert result.exit_code == 0 and len((tmp_path / "fixed" / "official.csv").read_text().splitlines()) == 2
