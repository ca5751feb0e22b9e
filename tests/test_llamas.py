"""LLAMAS scored as its culane_metric/evaluate.py scores it (golden values from
karstenBehrendt/unsupervised_llamas 9b99f46 run unchanged, tests/golden/llamas/expected.json):
the labels' four lanes from its spline creator, every frame's TP/FP/FN at several thresholds, the
totals, and where the script stops."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from roneld_eval.benchmarks.llamas.score import _predicted, score_llamas
from roneld_eval.cli import main
from roneld_eval.benchmarks.llamas.reader import every_label, four_lanes, read_label
from roneld_eval.errors import InputError
from roneld_eval.benchmarks.llamas.official import frame_counts, lane_mask

GOLDEN = Path(__file__).parent / "golden" / "llamas"
EXPECTED = json.loads((GOLDEN / "expected.json").read_text())
LABELS = GOLDEN / "labels"


def test_every_labels_four_lanes_equal_the_spline_creators():
    # get_horizontal_values_for_four_lanes: 4 x 717 values, ints and floats as the script has them
    found = every_label(LABELS)
    assert set(found) == set(EXPECTED["label_rows_sha256"])
    for key, path in found.items():
        rows = four_lanes(json.loads(path.read_text()))
        assert hashlib.sha256(json.dumps(rows).encode()).hexdigest() == EXPECTED["label_rows_sha256"][key], (
            key, EXPECTED["label_cases"].get(key))


@pytest.fixture(scope="module")
def truth():
    return {key: [lane_mask(lane.points, 1276, 717) for lane in read_label(path).lanes]
            for key, path in every_label(LABELS).items()}


@pytest.mark.parametrize("method", sorted(EXPECTED["methods"]))
def test_every_frame_equals_the_script(method, truth):
    expected = EXPECTED["methods"][method]
    thresholds = (0.5, 0.75, 0.9, 0.95)
    for key, masks in truth.items():
        predicted, _ = _predicted(GOLDEN / "predictions" / method / f"{key}.lines.txt", 30)
        counts = frame_counts(masks, predicted, thresholds)
        assert [list(map(int, row)) for row in counts] == [expected["frames"][key][str(t)] for t in thresholds], key


@pytest.mark.parametrize("method", ["shift_mixed", "few_points"])
def test_the_totals_equal_the_script_at_every_threshold(method):
    expected = EXPECTED["methods"][method]
    score = score_llamas(LABELS, {method: GOLDEN / "predictions" / method}, workers=1)
    for row in score.rows.rows:
        total = expected["totals"][str(float(row[1]))]
        assert (row[2], row[3], row[4], row[5], row[6], row[7]) == (
            total["TP"], total["FP"], total["FN"], total["Precision"], total["Recall"], total["F1"]), row
    assert score.mf1(method) == expected["mF1"]  # CLRNet's sum of F1 / 10 over np.linspace(0.5, 0.95, 10)
    official = expected["eval_predictions"]  # the script's own output, at 0.5
    assert score.rows.rows[0][2:5] == (official["TP"], official["FP"], official["FN"])
    assert score.rows.rows[0][7] == official["F1"]


def test_the_command_writes_the_tables_papers_print(tmp_path):
    result = CliRunner().invoke(main, ["score", "llamas", "--labels", str(LABELS), "--pred-root",
                                       str(GOLDEN / "predictions" / "shift_mixed"), "--out", str(tmp_path / "o")])
    assert result.exit_code == 0, result.output
    assert "| shift_mixed | 63.05 |" in result.output  # F1@0.5, the script's 0.6305
    summary = (tmp_path / "o" / "summary.csv").read_text().splitlines()
    assert summary[0] == "method,f1@0.50,f1@0.75,mf1"
    official = (tmp_path / "o" / "official.csv").read_text().splitlines()
    assert official[0] == "method,threshold,tp,fp,fn,precision,recall,f1,ap_l1,ap_l0,ap_r0,ap_r1,ap_mean"
    assert len(official) == 11 and official[1].endswith(",,,,,")  # no maps given: no AP


def _label(tmp_path: Path, record: dict) -> Path:
    path = tmp_path / "labels" / "rec" / "00000.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(record))
    return path


def _marker(x0, y0, x1, y1, z=5.0):
    return {"pixel_start": {"x": x0, "y": y0}, "pixel_end": {"x": x1, "y": y1},
            "world_start": {"x": 0.0, "y": 0.0, "z": z}, "world_end": {"x": 0.0, "y": 0.0, "z": z + 2}}


@pytest.mark.parametrize("lanes, message", [
    ([{"lane_id": "c0", "markers": [_marker(500, 700, 520, 650), _marker(540, 600, 560, 550)]}], "neither l nor r"),
    ([{"lane_id": "l0", "markers": []}], "has no markers"),
    ([{"lane_id": "l0", "markers": [_marker(500, 700, 500, 650), _marker(540, 600, 560, 600)]}],
     "neither horizontal nor vertical"),
    ([{"lane_id": "l0", "markers": [_marker(500, 717, 520, 650), _marker(540, 600, 560, 550)]}], "row 717"),
    ([{"lane_id": "l0", "markers": [_marker("a", 700, 520, 650), _marker(540, 600, 560, 550)]}], "not a number"),
])
def test_a_label_where_the_script_stops_is_refused_naming_it(tmp_path, lanes, message):
    path = _label(tmp_path, {"projection_matrix": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "lanes": lanes})
    with pytest.raises(InputError, match=message) as caught:
        read_label(path)
    assert str(path) in str(caught.value)


def test_two_splits_given_at_once_are_refused(tmp_path):
    for split in ("valid", "test"):
        path = tmp_path / split / "rec" / "00000.json"
        path.parent.mkdir(parents=True)
        path.write_text("{}")
    with pytest.raises(InputError, match="a second label known as rec/00000"):
        every_label(tmp_path)


def test_lanes_the_script_stops_at_are_left_out_and_said(tmp_path):
    # A prediction whose points are all one point (splprep: "1 <= k= 0 <=5 must hold") and a pair
    # of lanes both outside the image (IoU 0/0): the script stops; here one is left out and
    # counted, the other scores IoU 0.
    root = tmp_path / "pred"
    for key in every_label(LABELS):
        path = root / f"{key}.lines.txt"
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text("600 400 600 400\n-900 500 -800 600 -850 700\n")
    score = score_llamas(LABELS, {"odd": root}, iou="0.5", workers=1)
    assert score.stopping["odd"] == 90
    assert any("splprep refuses" in warning for warning in score.warnings)
    assert score.rows.rows[0][2] == 0
