"""VIL-100 scored as MMA-Net's evaluator scores it (golden values from yujun0-0/MMA-Net 8f95908,
tests/golden/vil100/mmanet_evaluator.json), its inputs (lists, sizes, scenarios), and the
command's errors; the real ground truth where ../shared is present."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest
from click.testing import CliRunner

from roneld_eval.benchmarks.vil100.score import _score_sequence, score_vil100
from roneld_eval.cli import main
from roneld_eval.errors import ConfigError, InputError
from roneld_eval.benchmarks.vil100.reader import read_vil100, scenarios_of
from roneld_eval.benchmarks.vil100.official import printed
from roneld_eval.benchmarks.vil100.temporal import sequence_counts

GOLDEN = Path(__file__).parent / "golden" / "vil100"
EXPECTED = json.loads((GOLDEN / "mmanet_evaluator.json").read_text())
TEMPORAL = json.loads((GOLDEN / "rvld_temporal.json").read_text())
SHARED = Path(__file__).resolve().parents[2] / "shared" / "data" / "vil100"


def golden_score(**options):
    return score_vil100(GOLDEN / "anno_txt", {"syn": GOLDEN / "pred_txt"}, list_file=GOLDEN / "test.txt",
                        sizes_file=GOLDEN / "test_sizes.json", **options)


def rows_of(score) -> dict:
    return {(row[1], row[2]): dict(zip(score.rows.columns, row)) for row in score.rows.rows}


@pytest.mark.parametrize("threshold, label", [("0.5", "0.50"), ("0.8", "0.80")])
def test_sequences_and_overall_equal_the_official_evaluator(threshold, label):
    expected = EXPECTED["thresholds"][threshold]
    rows = rows_of(golden_score())
    for sequence, counts in expected["sequences"].items():
        row = rows[(sequence, label)]
        assert (row["tp"], row["fp"], row["fn"]) == (counts["tp"], counts["fp"], counts["fn"])
        assert printed(row["miou"]) == counts["miou_printed"]
    every = rows[("all", label)]
    overall = expected["overall"]
    assert (every["tp"], every["fp"], every["fn"]) == (overall["tp"], overall["fp"], overall["fn"])
    assert every["f1"] == overall["f1"]
    assert every["miou"] == pytest.approx(overall["miou"], abs=1e-12)  # evaluate_iou.py sums in os.listdir order


@pytest.mark.parametrize("threshold", [0.5, 0.8])
def test_every_frame_equals_the_official_evaluator(threshold):
    dataset = read_vil100(GOLDEN / "anno_txt", GOLDEN / "test.txt", sizes_file=GOLDEN / "test_sizes.json")
    for sequence, frames in dataset.sequences.items():
        scored = _score_sequence((frames, dataset.labels, (GOLDEN / "pred_txt",), *dataset.sizes[sequence], 30,
                                  False, "lines", None)).frames[0]
        expected = EXPECTED["thresholds"][str(threshold)]["frames"][sequence]
        assert [f"/{relpath}.jpg" for relpath in frames] == [frame["frame"] for frame in expected]
        for (result, miou), frame in zip(scored, expected):
            tp = result.true_positives(threshold)
            assert (tp, result.n_pred - tp, result.n_gt - tp) == (frame["tp"], frame["fp"], frame["fn"]), frame
            assert miou == frame["miou"], frame  # bit for bit


@pytest.mark.parametrize("tau, label", [("0.5", "0.50"), ("0.8", "0.80")])
def test_temporal_counts_equal_rvlds_script(tau, label):
    score = golden_score()
    expected = TEMPORAL[tau]
    counts = score.temporal_overall[("syn", label)]
    assert (counts.stable, counts.jump, counts.missing) == (expected["stable"], expected["jump"], expected["missing"])
    dataset = read_vil100(GOLDEN / "anno_txt", GOLDEN / "test.txt", sizes_file=GOLDEN / "test_sizes.json")
    transitions = []  # the script's results_t: one (Ns, Nj, Nm) per frame after a sequence's first
    for sequence, frames in dataset.sequences.items():
        piece = _score_sequence((frames, dataset.labels, (GOLDEN / "pred_txt",), *dataset.sizes[sequence], 30, True,
                                 "lines", None))
        for k in range(1, len(frames)):
            step = sequence_counts([[], piece.links[k]], [piece.assigned[0][k - 1], piece.assigned[0][k]], float(tau))
            transitions.append([step.stable, step.jump, step.missing])
    assert transitions == expected["per_transition"]


def test_the_pairs_depend_on_the_ground_truth_alone():
    with_predictions = golden_score().temporal_overall[("syn", "0.50")]
    against_itself = score_vil100(GOLDEN / "anno_txt", {"gt": GOLDEN / "anno_txt"}, list_file=GOLDEN / "test.txt",
                                  sizes_file=GOLDEN / "test_sizes.json").temporal_overall[("gt", "0.50")]
    assert against_itself.pairs == with_predictions.pairs and against_itself.stable == against_itself.pairs


def test_the_command_writes_official_csv_and_prints_the_summary(tmp_path):
    result = CliRunner().invoke(main, ["score", "vil100", "--labels", str(GOLDEN / "anno_txt"), "--pred-root",
                                       f"syn={GOLDEN / 'pred_txt'}", "--sizes", str(GOLDEN / "test_sizes.json"),
                                       "--out", str(tmp_path / "out"), "--quiet"])
    assert result.exit_code == 0, result.output
    text = (tmp_path / "out" / "official.csv").read_text()
    assert text.splitlines()[0] == "method,category,threshold,tp,fp,fn,precision,recall,f1,miou,sequences"
    # The overall F1 and mIoU as evaluate_iou.py prints them (the full float), not rounded to 6 decimals
    for threshold, label in (("0.5", "0.50"), ("0.8", "0.80")):
        overall = EXPECTED["thresholds"][threshold]["overall"]
        tp, fp, fn = overall["tp"], overall["fp"], overall["fn"]
        assert (f"syn,all,{label},{tp},{fp},{fn},{tp / (tp + fp)!r},{tp / (tp + fn)!r},{overall['f1']!r},"
                f"{overall['miou']!r},2") in text.splitlines()
    assert "syn,all,0.50,14,9,11,0.6086956521739131,0.56,0.5833333333333334,0.467708,2" in text.splitlines()
    assert "F1@0.80 (%)" in (tmp_path / "out" / "summary.md").read_text()
    temporal = (tmp_path / "out" / "temporal.csv").read_text().splitlines()
    assert temporal[0] == "method,category,tau,pairs,stable,jump,missing,rs,rj,rm"
    assert "syn,all,0.80,10,3,6,1,0.3,0.6,0.1" in temporal
    summary = (tmp_path / "out" / "summary.csv").read_text().splitlines()
    # Acc/FP/FN beside them (RVLD's version only: lane files; checked in tests/test_vil100_acc.py)
    assert summary[0] == ("method,category,f1@0.50,f1@0.80,miou,rs@0.50,rj@0.50,rm@0.50,rs@0.80,rj@0.80,rm@0.80,"
                          "acc_rvld,fp_rvld,fn_rvld")
    assert summary[1].startswith("syn,all,0.5833333333333334,0.41666666666666663,0.467708,0.6,0.4,0.0,0.3,0.6,0.1,")
    assert len(summary) == 2


def _copy_set(tmp_path: Path, names: dict[str, str]) -> Path:
    """The golden set with its sequences renamed (scenario codes in front)."""
    root = tmp_path / "set"
    for part in ("anno_txt", "pred_txt"):
        for old, new in names.items():
            shutil.copytree(GOLDEN / part / old, root / part / new)
    sizes = json.loads((GOLDEN / "test_sizes.json").read_text())
    (root / "sizes.json").write_text(json.dumps({new: sizes[old] for old, new in names.items()}))
    return root


def test_without_the_temporal_metrics_there_is_no_temporal_csv(tmp_path):
    result = CliRunner().invoke(main, ["score", "vil100", "--labels", str(GOLDEN / "anno_txt"), "--pred-root",
                                       str(GOLDEN / "pred_txt"), "--sizes", str(GOLDEN / "test_sizes.json"),
                                       "--no-temporal", "--out", str(tmp_path / "out")])
    assert result.exit_code == 0, result.output
    assert sorted(p.name for p in (tmp_path / "out").iterdir() if not p.name.startswith(".")) == [
        "acc.csv", "official.csv", "summary.csv", "summary.md"]
    assert "Rs@" not in result.output


def test_scenarios_pool_their_sequences_as_the_overall_row_does(tmp_path):
    root = _copy_set(tmp_path, {"synA_frames": "12_Road001_frames", "synB_frames": "2_Road002_frames"})
    assert scenarios_of("12_Road001_frames") == (1, 2) and scenarios_of("1269_Road023_Trim003_frames") == (1, 2, 6, 9)
    score = score_vil100(root / "anno_txt", {"m": root / "pred_txt"}, sizes_file=root / "sizes.json")
    rows = rows_of(score)
    crowded, curved, every = (rows[(name, "0.50")] for name in ("scenario 1 (crowded)", "scenario 2 (curved road)",
                                                                 "all"))
    first = rows[("12_Road001_frames", "0.50")]
    assert (crowded["tp"], crowded["fp"], crowded["fn"], crowded["sequences"]) == (first["tp"], first["fp"],
                                                                                  first["fn"], 1)
    assert crowded["miou"] == float(printed(first["miou"]))
    assert {key: curved[key] for key in ("tp", "fp", "fn", "miou", "sequences")} == {
        key: every[key] for key in ("tp", "fp", "fn", "miou", "sequences")}


def test_sizes_from_images_or_annotations_give_the_same_scores(tmp_path):
    sizes = json.loads((GOLDEN / "test_sizes.json").read_text())
    images, annotations = tmp_path / "JPEGImages", tmp_path / "Json"
    for sequence, size in sizes.items():
        (images / sequence).mkdir(parents=True)
        (annotations / sequence).mkdir(parents=True)
        cv2.imwrite(str(images / sequence / "00000.jpg"), np.zeros((size["height"], size["width"]), np.uint8))
        (annotations / sequence / "00000.jpg.json").write_text(json.dumps({"info": size, "annotations": {}}))
    expected = golden_score().rows
    mmanet_list = tmp_path / "test.txt"  # MMA-Net's own list form
    mmanet_list.write_text("".join(f"/JPEGImages/{line}.jpg\n" for line in (GOLDEN / "test.txt").read_text().split()))
    for source in ({"image_root": images}, {"json_root": annotations}):
        score = score_vil100(GOLDEN / "anno_txt", {"syn": GOLDEN / "pred_txt"}, list_file=mmanet_list, **source)
        assert score.rows == expected


@pytest.mark.parametrize("arguments, message", [
    ([], "give the sequences' image sizes once: --image-root"),
    (["--sizes", "{sizes}", "--image-root", "{golden}"], "give the sequences' image sizes once"),
    (["--sizes", "{short}"], "{short}: no size for sequence synB_frames"),
    (["--sizes", "{bad}"], "{bad}: synA_frames: a size is a width and a height in pixels (1..16384), got [0, 5]"),
    (["--sizes", "{deep}"], "{deep}: not a file of sizes: nested too deeply"),
    (["--image-root", "{images}"], "{images}/synB_frames/00000.png: image: a size is a width and a height in pixels "
                                   "(1..16384), got [60000, 60000]"),
    (["--image-root", "{junk}"], "{junk}/synA_frames/00000.jpg: not a JPEG or PNG whose size can be read"),
    (["--sizes", "{sizes}", "--list", "{list}"], "{list}:1: 'synA_frames' is not <sequence>/<frame>"),
])
def test_bad_input_is_one_line(tmp_path, arguments, message):
    paths = {"sizes": GOLDEN / "test_sizes.json", "golden": GOLDEN, "short": tmp_path / "short.json",
             "bad": tmp_path / "bad.json", "list": tmp_path / "list.txt", "deep": tmp_path / "deep.json",
             "images": tmp_path / "images", "junk": tmp_path / "junk"}
    paths["deep"].write_text("[" * 100_000 + "]" * 100_000)
    for sequence in ("synA_frames", "synB_frames"):
        (paths["images"] / sequence).mkdir(parents=True)
        (paths["junk"] / sequence).mkdir(parents=True)
        (paths["junk"] / sequence / "00000.jpg").write_bytes(b"not an image at all")
    cv2.imwrite(str(paths["images"] / "synA_frames" / "00000.png"), np.zeros((8, 8), np.uint8))
    header = bytearray((paths["images"] / "synA_frames" / "00000.png").read_bytes())
    header[16:24] = (60000).to_bytes(4, "big") * 2  # a 60000x60000 image's header, 100 bytes on disk
    (paths["images"] / "synB_frames" / "00000.png").write_bytes(bytes(header))
    paths["short"].write_text(json.dumps({"synA_frames": [1920, 1080]}))
    paths["bad"].write_text(json.dumps({"synA_frames": [0, 5], "synB_frames": [960, 480]}))
    paths["list"].write_text("synA_frames\n")
    result = CliRunner().invoke(main, ["score", "vil100", "--labels", str(GOLDEN / "anno_txt"), "--pred-root",
                                       str(GOLDEN / "pred_txt"), *(a.format(**paths) for a in arguments)])
    assert result.exit_code == 2
    assert result.output.startswith(f"error: {message.format(**paths)}"), result.output
    assert result.output.count("\n") == 1


def test_a_wrong_labels_folder_is_refused(tmp_path):
    result = CliRunner().invoke(main, ["score", "vil100", "--labels", str(GOLDEN), "--pred-root",
                                       str(GOLDEN / "pred_txt"), "--sizes", str(GOLDEN / "test_sizes.json")])
    assert result.exit_code == 2 and "is this MMA-Net's anno_txt folder?" in result.output


def test_run_on_vil100_without_data_says_what_it_needs():
    result = CliRunner().invoke(main, ["run", "--dataset", "vil100", "--quiet"])
    assert result.exit_code == 2
    assert result.output == "error: VIL-100 has no bundled fixture: give --data-root and --maps-root\n"


@pytest.mark.long
@pytest.mark.skipif(not SHARED.is_dir(), reason="needs ../shared/data/vil100")
def test_the_real_ground_truth_against_itself_scores_one(tmp_path):
    score = score_vil100(SHARED / "anno_txt", {"gt": SHARED / "anno_txt"}, list_file=SHARED / "test.txt",
                         sizes_file=SHARED / "test_sizes.json", workers=2)
    rows = rows_of(score)
    assert score.n_frames == 2000 and score.n_sequences == 20
    lanes = sum(len((SHARED / "anno_txt" / f"{line}.lines.txt").read_text().splitlines())
                for line in (SHARED / "test.txt").read_text().split())
    for label in ("0.50", "0.80"):
        every = rows[("all", label)]
        assert (every["tp"], every["fp"], every["fn"], every["f1"], every["miou"]) == (lanes, 0, 0, 1.0, 1.0)
        # RVLD's script on the ground truth itself (4d90de1, tau 0.5): Ns 8017, Nj 0, Nm 0
        linked = score.temporal_overall[("gt", label)]
        assert (linked.stable, linked.jump, linked.missing) == (8017, 0, 0)
    # RVLD's evaluate_acc.py (4d90de1) on the same files stops at 108 lanes repeating a y; keeping
    # each lane's first point at a y gives 0.98, what the script gives once those points are dropped.
    rvld = score.acc_overall[("gt", "rvld")]
    assert (rvld.accuracy, rvld.fp, rvld.fn, rvld.frames, rvld.stopping) == (0.98, 0.0, 0.0, 2000, 108)
    scenarios = {name for name, _ in rows if name.startswith("scenario")}
    assert scenarios >= {"scenario 0 (normal)", "scenario 9 (crossroad)"}


def test_a_lane_drawn_where_it_reaches_has_the_pixels_of_the_whole_canvas():
    """lane_mask draws one polyline on the part of the canvas a lane can reach; the script draws
    every segment with cv2.line on the whole canvas (full_canvas_mask): the same pixels, for lanes
    inside, across and outside the image's edges."""
    from roneld_eval.metrics.line_masks import full_canvas_mask
    from roneld_eval.benchmarks.vil100.temporal import _interpolated, lane_mask
    from roneld_eval.model import Lane

    rng = np.random.default_rng(3)
    for _ in range(300):
        width, height = (960, 480) if rng.random() < 0.5 else (1920, 1080)
        count = int(rng.integers(2, 12))
        ys = np.sort(rng.uniform(-100, height + 100, count))[::-1]
        xs = rng.uniform(-300, width + 300) + np.cumsum(rng.normal(0, 40, count))
        lane = Lane(np.stack([xs, ys], 1))
        fast = lane_mask(lane, width, height)
        reference = full_canvas_mask(_interpolated(lane).astype(np.int32), width, height, 30)
        assert (fast.top, fast.left, fast.area) == (reference.top, reference.left, reference.area)
        assert np.array_equal(fast.pixels, reference.pixels)


@pytest.mark.parametrize("command, root", [("vil100", "--labels"), ("openlane", "--labels"),
                                           ("culane", "--data-root")])
def test_a_lane_width_beyond_the_bound_is_refused_before_any_work(command, root):
    result = CliRunner().invoke(main, ["score", command, "--width", "1001", root, "x", "--pred-root", "x"])
    assert result.exit_code == 2 and "1001 is not in the range 2<=x<=1000" in result.output
    with pytest.raises(ConfigError, match="at most 1000 px, got 1000000000"):
        score_vil100(GOLDEN / "anno_txt", GOLDEN / "pred_txt", sizes_file=GOLDEN / "test_sizes.json", width=10**9)


def test_listed_frames_without_ground_truth_are_said_and_refused_under_strict(tmp_path):
    listing = tmp_path / "list.txt"
    listing.write_text("synA_frames/00000\nsynA_frames/00001\nsynA_frames/00002\n")  # labels every third frame
    arguments = ["score", "vil100", "--labels", str(GOLDEN / "anno_txt"), "--pred-root", str(GOLDEN / "pred_txt"),
                 "--sizes", str(GOLDEN / "test_sizes.json"), "--list", str(listing), "--quiet"]
    result = CliRunner().invoke(main, arguments + ["--out", str(tmp_path / "out")])
    assert result.exit_code == 0
    assert result.stderr.startswith("warning: 2 of 3 listed frames have no ground-truth file (first: "
                                    f"{GOLDEN / 'anno_txt' / 'synA_frames' / '00001.lines.txt'})")
    strict = CliRunner().invoke(main, arguments + ["--strict"])
    assert strict.exit_code == 2 and "--strict needs every one" in strict.output


def test_a_sequence_named_like_a_summary_row_is_refused(tmp_path):
    root = _copy_set(tmp_path, {"synA_frames": "all", "synB_frames": "2_Road002_frames"})
    with pytest.raises(InputError, match="a sequence named 'all' would be mistaken"):
        score_vil100(root / "anno_txt", {"m": root / "pred_txt"}, sizes_file=root / "sizes.json")


@pytest.mark.parametrize("content, problem", [
    ("[1, 2]", "not a VIL-100 annotation: no `info` object with the image's width and height"),
    ('{"annotations": {}}', "not a VIL-100 annotation: no `info` object with the image's width and height"),
    ("{", "not a VIL-100 annotation: Expecting property name"),
    (None, "is a folder"),
])
def test_a_bad_annotation_is_named_with_its_problem(tmp_path, content, problem):
    for sequence in ("synA_frames", "synB_frames"):
        (tmp_path / sequence).mkdir()
        (tmp_path / sequence / "00000.jpg.json").write_text('{"info": {"width": 960, "height": 480}}')
    bad = tmp_path / "synB_frames" / "00000.jpg.json"
    if content is None:
        bad.unlink()
        bad.mkdir()
    else:
        bad.write_text(content)
    result = CliRunner().invoke(main, ["score", "vil100", "--labels", str(GOLDEN / "anno_txt"), "--pred-root",
                                       str(GOLDEN / "pred_txt"), "--json-root", str(tmp_path), "--quiet"])
    assert result.exit_code == 2 and result.output.startswith(f"error: {bad}: ") and problem in result.output
