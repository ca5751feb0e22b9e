"""`score openlane3d` against OpenLane's lane3d evaluator (tests/golden/openlane3d: its per-frame
returns, matchings and totals on generated sets, with the tool's commit): every count, matching and
error equal frame by frame, the totals to the bit; without OR-Tools, the same total cost on every
frame; the files as untrusted input; shards, scenarios and several methods."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from roneld_eval.benchmarks.openlane3d import official
from roneld_eval.metrics import lane3d_flow
from roneld_eval.benchmarks.openlane3d.official import frame_counts, ground_truth_lanes
from roneld_eval.benchmarks.openlane3d.reader import json_path, read_prediction, read_truth
from roneld_eval.benchmarks.openlane3d.score import COLUMNS, printed, score_openlane3d
from roneld_eval.benchmarks.openlane3d.synth import synth_openlane3d, with_probabilities
from roneld_eval.cli import main

GOLDEN = Path(__file__).parent / "golden" / "openlane3d"
PRINTED = ("f", "recall", "precision", "category_accuracy", "x_error_near", "x_error_far", "z_error_near",
           "z_error_far")
# the official __main__'s print, word for word
OFFICIAL_PRINT = ("===> Evaluation on validation set: \nlaneline F-measure {:.8} \nlaneline Recall  {:.8} \n"
                  "laneline Precision  {:.8} \nlaneline Category Accuracy  {:.8} \nlaneline x error (close)  {:.8} m\n"
                  "laneline x error (far)  {:.8} m\nlaneline z error (close)  {:.8} m\n"
                  "laneline z error (far)  {:.8} m\n")


def invoke(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def _set(tmp_path_factory, seed: int) -> Path:
    out = tmp_path_factory.mktemp(f"ol3d{seed}")
    synth_openlane3d(out, clips=12, frames=10, seed=seed)
    return out


@pytest.fixture(scope="module", params=[0, 1])
def golden_set(request, tmp_path_factory):
    golden = json.loads((GOLDEN / f"synth_seed{request.param}.json").read_text())
    assert golden["set"]["command"].endswith(f"--clips 12 --frames 10 --seed {request.param}")
    return _set(tmp_path_factory, request.param), golden


def _frames(root: Path):
    for relpath in (root / "test_list.txt").read_text().split():
        truth = read_truth(json_path(root / "labels", relpath))
        predicted = read_prediction(json_path(root / "predictions", relpath))
        yield truth, frame_counts(list(predicted.lanes), list(predicted.categories),
                                  ground_truth_lanes(truth.extrinsic, truth.lanes), list(truth.visibility),
                                  list(truth.categories))


def test_every_frame_is_the_evaluators_count_for_count(golden_set):
    root, golden = golden_set
    pytest.importorskip("ortools")
    compared = 0
    for (truth, counts), theirs in zip(_frames(root), golden["frames"], strict=True):
        assert truth.key == theirs["file_path"]
        assert list(counts.counts()) == theirs["counts"], truth.key
        assert [list(pair) for pair in counts.pairs] == theirs["matching"], truth.key
        assert counts.errors.T.tolist() == theirs["errors"], truth.key  # bit for bit
        compared += 1
    assert compared == 120
    assert sum(frame["counts"][5] for frame in golden["frames"]) > 200  # matches enough to mean something


def test_the_totals_and_the_printed_lines_are_the_evaluators(golden_set):
    root, golden = golden_set
    pytest.importorskip("ortools")
    score = score_openlane3d(root / "labels", root / "predictions", root / "test_list.txt", workers=1)
    assert score is not None
    values = [score.value("predictions", column) for column in PRINTED]
    sums = [score.value("predictions", column) for column in COLUMNS[3:9]]
    assert values + sums == golden["output_stats"]
    assert OFFICIAL_PRINT.format(*values) + "\n" == golden["printed"]  # print() adds the last line end
    assert " | ".join(printed(v) for v in values) in invoke(
        "score", "openlane3d", "--labels", root / "labels", "--pred-root", root / "predictions", "--list",
        root / "test_list.txt", "--workers", "1").output


def test_without_ortools_every_matching_costs_what_the_evaluators_costs(golden_set, monkeypatch):
    root, golden = golden_set
    monkeypatch.setattr(lane3d_flow, "flow_solver", lambda: None)
    other = 0
    for (truth, counts), theirs in zip(_frames(root), golden["frames"], strict=True):
        assert sum(pair[2] for pair in counts.pairs) == sum(pair[2] for pair in theirs["matching"]), truth.key
        if [list(pair) for pair in counts.pairs] == theirs["matching"]:
            assert list(counts.counts()) == theirs["counts"]
        else:
            other += 1
    assert other <= 3  # the frames with several matchings of the least cost (a duplicated lane)
    result = invoke("score", "openlane3d", "--labels", root / "labels", "--pred-root", root / "predictions",
                    "--workers", "1")
    assert result.exit_code == 0 and "OR-Tools is not installed" in result.output


@pytest.fixture(scope="module", params=[0, 1])
def training_set(request, tmp_path_factory):
    """A golden set's results as PersFormer's training-time evaluation takes them."""
    golden = json.loads((GOLDEN / f"persformer_train_seed{request.param}.json").read_text())
    root = _set(tmp_path_factory, request.param)
    with_probabilities(root / "predictions", root / "train", seed=request.param)
    return root, golden


def test_the_training_time_protocol_is_persformers_frame_by_frame(training_set):
    root, golden = training_set
    pytest.importorskip("ortools")
    for relpath, theirs in zip((root / "test_list.txt").read_text().split(), golden["frames"], strict=True):
        truth = read_truth(json_path(root / "labels", relpath))
        predicted = read_prediction(json_path(root / "train", relpath), 0.5)
        assert list(predicted.categories) == theirs["pred_category"], relpath  # kept above 0.5, the first argmax
        counts = frame_counts(list(predicted.lanes), list(predicted.categories),
                              ground_truth_lanes(truth.extrinsic, truth.lanes), list(truth.visibility),
                              list(truth.categories))
        assert list(counts.counts()) == theirs["counts"], relpath
        assert [list(pair) for pair in counts.pairs] == theirs["matching"], relpath
        assert counts.errors.T.tolist() == theirs["errors"], relpath
    score = score_openlane3d(root / "labels", root / "train", root / "test_list.txt", protocol="persformer-train",
                             workers=1)
    assert score is not None
    assert [score.value("train", c) for c in PRINTED] + [score.value("train", c) for c in COLUMNS[3:9]] == \
        golden["output_stats"]
    result = invoke("score", "openlane3d", "--labels", root / "labels", "--pred-root", root / "train",
                    "--protocol", "persformer-train", "--prob-threshold", "0.5", "--workers", "1")
    assert result.exit_code == 0 and "above 0.5, its category the most probable" in result.output


def test_protocol_options_are_checked(tmp_path):
    root = tmp_path / "set"
    synth_openlane3d(root, clips=1, frames=2, seed=8)
    common = ["score", "openlane3d", "--labels", root / "labels", "--pred-root", root / "predictions"]
    for extra, said in ((["--prob-threshold", "0.3"], "is for --protocol persformer-train"),
                        (["--protocol", "persformer-train", "--prob-threshold", "1.5"], "from 0 to 1"),
                        (["--protocol", "persformer-train"], "`laneLines` must be a list")):
        result = invoke(*common, *extra)
        assert result.exit_code == 2 and said in result.output and "Traceback" not in result.output, result.output


def test_shards_merge_and_scenarios(tmp_path):
    root = tmp_path / "set"
    synth_openlane3d(root, clips=5, frames=4, seed=4)
    listed = (root / "test_list.txt").read_text().split()
    (root / "scenarios").mkdir()
    (root / "scenarios" / "curve_case.txt").write_text("\n".join(listed[3:11]) + "\n")
    for relpath in listed[:2]:  # a case as lane3d_1000/test/ holds it: a folder of its annotations
        target = json_path(root / "scenarios" / "night_case", relpath)
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_bytes(json_path(root / "labels", relpath).read_bytes())
    common = ["--labels", root / "labels", "--pred-root", f"det={root / 'predictions'}", "--list",
              root / "test_list.txt", "--scenarios", root / "scenarios", "--workers", "1"]
    assert invoke("score", "openlane3d", *common, "--out", tmp_path / "whole").exit_code == 0
    for k in (1, 2, 3):
        result = invoke("score", "openlane3d", *common, "--shard", f"{k}/3", "--out", tmp_path / f"part{k}")
        assert result.exit_code == 0, result.output
    merged = invoke("merge", *(tmp_path / f"part{k}" for k in (1, 2, 3)), "--out", tmp_path / "merged")
    assert merged.exit_code == 0, merged.output
    for name in ("official.csv", "summary.md"):
        assert (tmp_path / "merged" / name).read_bytes() == (tmp_path / "whole" / name).read_bytes()
    whole = (tmp_path / "whole" / "official.csv").read_text().splitlines()
    assert [line.split(",")[1] for line in whole[1:]] == ["all", "curve_case", "night_case"]
    (tmp_path / "curve.txt").write_text("\n".join(listed[3:11]) + "\n")
    alone = score_openlane3d(root / "labels", {"det": root / "predictions"}, tmp_path / "curve.txt", workers=1)
    assert alone is not None and alone.rows.rows[0][2:] == next(
        row for row in score_openlane3d(root / "labels", {"det": root / "predictions"}, root / "test_list.txt",
                                        scenarios=root / "scenarios", workers=1).rows.rows
        if row[1] == "curve_case")[2:]


def test_a_missing_result_is_a_frame_without_lanes_and_strict_refuses_it(tmp_path):
    root = tmp_path / "set"
    synth_openlane3d(root, clips=2, frames=3, seed=5)
    first = (root / "test_list.txt").read_text().split()[0]
    json_path(root / "predictions", first).unlink()
    score = score_openlane3d(root / "labels", root / "predictions", root / "test_list.txt", workers=1)
    assert score is not None and score.value("predictions", "frames") == 6
    refused = invoke("score", "openlane3d", "--labels", root / "labels", "--pred-root", root / "predictions",
                     "--strict")
    assert refused.exit_code == 2 and "Traceback" not in refused.output


@pytest.mark.parametrize("where, edit, said", [
    ("labels", lambda r: r.pop("file_path"), "file_path"),
    ("labels", lambda r: r.update(extrinsic=[[1, 0, 0], [0, 1, 0]]), "4 x 4"),
    ("labels", lambda r: r["lane_lines"][0].update(visibility=[1.0]), "visibility"),
    ("labels", lambda r: r["lane_lines"][0]["xyz"][0].append(1.0), "equal lengths"),
    ("labels", lambda r: r["lane_lines"][0].update(category="1"), "category"),
    ("predictions", lambda r: r.update(file_path="validation/other.jpg"), "not its label's"),
    ("predictions", lambda r: r.update(lane_lines={}), "list of lanes"),
    ("predictions", lambda r: r["lane_lines"][0].update(xyz=[]), "at least one"),
    ("predictions", lambda r: r["lane_lines"][0].update(xyz=[[1.0, "x", 2.0]]), "finite numbers"),
    ("predictions", lambda r: r["lane_lines"][0].update(xyz=[[1.0, 2.0, 3.0], [1.0, 2.0]]), "[x, y, z]"),
])
def test_a_file_the_evaluator_cannot_use_is_refused_naming_it(tmp_path, where, edit, said):
    root = tmp_path / "set"
    synth_openlane3d(root, clips=1, frames=6, seed=6)
    target = next(path for path in sorted((root / where).rglob("*.json"))
                  if json.loads(path.read_text())["lane_lines"])
    record = json.loads(target.read_text())
    edit(record)
    target.write_text(json.dumps(record))
    result = invoke("score", "openlane3d", "--labels", root / "labels", "--pred-root", root / "predictions",
                    "--workers", "1")
    assert result.exit_code == 2, result.output
    assert target.name in result.output and said in result.output and "Traceback" not in result.output


def test_synth_writes_the_same_set_twice(tmp_path):
    synth_openlane3d(tmp_path / "a", clips=2, frames=3, seed=9)
    synth_openlane3d(tmp_path / "b", clips=2, frames=3, seed=9)
    for path in sorted((tmp_path / "a").rglob("*.*")):
        assert (tmp_path / "b" / path.relative_to(tmp_path / "a")).read_bytes() == path.read_bytes()


def test_resampling_is_interp1ds(tmp_path):
    from scipy.interpolate import interp1d

    rng = np.random.default_rng(0)
    for _ in range(200):
        n = int(rng.integers(2, 12))
        lane = np.column_stack([rng.normal(0, 5, n), rng.uniform(-10, 130, n), rng.normal(0, 1, n)])
        x, z, inside = lane3d_flow.resample(lane)
        assert x.tolist() == interp1d(lane[:, 1], lane[:, 0], fill_value="extrapolate")(lane3d_flow.Y_SAMPLES).tolist()
        assert z.tolist() == interp1d(lane[:, 1], lane[:, 2], fill_value="extrapolate")(lane3d_flow.Y_SAMPLES).tolist()
        assert inside.dtype == np.float32


def test_the_metric_in_memory_gives_what_the_command_writes(golden_set):
    import roneld_eval

    root, golden = golden_set
    pytest.importorskip("ortools")
    metric = roneld_eval.metric("openlane3d", labels=str(root / "labels"), list_file=str(root / "test_list.txt"))
    listed = (root / "test_list.txt").read_text().split()
    for relpath in reversed(listed[1:]):  # any order; the first frame never updated: no lanes
        predicted = read_prediction(json_path(root / "predictions", relpath))
        metric.update(relpath, list(predicted.lanes), categories=list(predicted.categories))
    without_first = root / "without_first"  # the same results, the first frame's file missing: no lanes
    if not without_first.exists():
        for relpath in listed[1:]:
            target = json_path(without_first, relpath)
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_bytes(json_path(root / "predictions", relpath).read_bytes())
    score = score_openlane3d(root / "labels", {"-": without_first}, root / "test_list.txt", workers=1)
    assert score is not None
    assert metric.tables()["official"].rows == score.rows.rows
    values = metric.compute()
    assert values["F"] == score.value("-", "f") and values["z_error_far"] == score.value("-", "z_error_far")
    with pytest.raises(Exception, match="categories"):
        metric.update(listed[0], [np.zeros((3, 3))])


def test_the_training_time_metric_in_memory_takes_each_lanes_probabilities(training_set):
    import roneld_eval

    root, golden = training_set
    pytest.importorskip("ortools")
    metric = roneld_eval.metric("openlane3d", labels=str(root / "labels"), list_file=str(root / "test_list.txt"),
                                protocol="persformer-train")
    for relpath in (root / "test_list.txt").read_text().split():
        record = json.loads(json_path(root / "train", relpath).read_text())
        metric.update(relpath, [np.array(lane) for lane in record["laneLines"]], scores=record["laneLines_prob"])
    row = metric.tables()["official"].rows[0]
    assert [row[COLUMNS.index(c)] for c in PRINTED] + list(row[3:9]) == golden["output_stats"]


def test_what_the_evaluator_would_score_wrongly_or_forever_is_refused(tmp_path, monkeypatch):
    root = tmp_path / "set"
    synth_openlane3d(root, clips=1, frames=4, seed=12)
    listed = (root / "test_list.txt").read_text().split()
    common = ["score", "openlane3d", "--labels", root / "labels", "--pred-root", root / "predictions", "--workers", "1"]
    # two labels of one file_path: the evaluator keeps the last and scores it twice
    label, result = json_path(root / "labels", listed[1]), json_path(root / "predictions", listed[1])
    for path in (label, result):
        record = json.loads(path.read_text())
        record["file_path"] = json.loads(json_path(root / "labels", listed[0]).read_text())["file_path"]
        path.write_text(json.dumps(record))
    twice = invoke(*common)
    assert twice.exit_code == 2 and "each label needs its own" in twice.output and label.name in twice.output
    synth_openlane3d(root, clips=1, frames=4, seed=12)
    # a distance past the evaluator's integer cost: its min-cost flow runs without end
    record = json.loads(result.read_text())
    assert record["lane_lines"]
    record["lane_lines"][0]["xyz"] = [[0.0, y, 1e300] for y in (5.0, 50.0)]
    result.write_text(json.dumps(record))
    far = invoke(*common)
    assert far.exit_code == 2 and "beyond the evaluator's integer cost" in far.output and result.name in far.output
    synth_openlane3d(root, clips=1, frames=4, seed=12)
    # the file protocol keeps every lane: a threshold for it is a mistake, even the default one
    assert "is for --protocol persformer-train" in invoke(*common, "--prob-threshold", "0.5").output
    # results in the other format: the message names the protocol that reads them
    with_probabilities(root / "predictions", tmp_path / "train")
    hint = invoke("score", "openlane3d", "--labels", root / "labels", "--pred-root", tmp_path / "train")
    assert hint.exit_code == 2 and "give --protocol persformer-train" in hint.output
    # a missing result is a frame without lanes, said in a line (the evaluator stops on it)
    result.unlink()
    missing = invoke(*common, "--out", root / "labels" / "scores")  # an output folder inside the labels, too
    assert missing.exit_code == 0 and "1 of 4 listed images have no result file" in missing.output
    again = invoke(*common, "--out", tmp_path / "again")  # the labels' own output folder is not read as labels
    assert again.exit_code == 0, again.output
    inside = (root / "labels" / "scores" / "official.csv").read_text()
    assert inside == (tmp_path / "again" / "official.csv").read_text()


def test_a_frame_of_many_lanes_is_paired_a_block_at_a_time_with_the_same_bits(monkeypatch):
    rng = np.random.default_rng(3)
    gt = rng.normal(0, 3, (7, 100, 2))
    pred = gt[rng.permutation(7)][:5] + rng.normal(0, 0.5, (5, 100, 2))
    gt_visible = (rng.random((7, 100)) < 0.8).astype(float)
    pred_visible = (rng.random((5, 100)) < 0.8).astype(float)
    whole = lane3d_flow.pair_distances(gt, pred, gt_visible, pred_visible, official.PAIR_RULE)
    monkeypatch.setattr(lane3d_flow, "PAIRS_AT_ONCE", 6)  # a row of ground truth a block
    blocked = lane3d_flow.pair_distances(gt, pred, gt_visible, pred_visible, official.PAIR_RULE)
    for a, b in zip(whole, blocked):
        assert a.shape == b.shape and a.tobytes() == b.tobytes()
