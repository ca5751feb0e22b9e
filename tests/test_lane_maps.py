"""RONELD on another detector's lanes: lane files drawn into maps (`--maps-format lanes`)."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from roneld_eval.benchmarks import benchmark_for
from roneld_eval.cli import main
from roneld_eval.config import MapsConfig
from roneld_eval.errors import InputError
from roneld_eval.geometry import MapGeometry
from roneld_eval.maps import load_maps
from roneld_eval.maps.lanes import RIDGE_HALF_WIDTH_PX, draw_lane_maps
from roneld_eval.model import Lane
from roneld_eval.benchmarks.culane.synth import synth_culane
from roneld_eval.benchmarks.tusimple.synth import synth_tusimple

GEOMETRY = MapGeometry(1640, 590, 800, 288)
MAPS = MapsConfig(format="lanes")
CULANE_LANES = benchmark_for("culane").detector_lanes
TUSIMPLE_LANES = benchmark_for("tusimple").detector_lanes


def lane(*points) -> Lane:
    return Lane(np.array(points, np.float64))


def invoke(args):
    result = CliRunner().invoke(main, args)
    assert "Traceback" not in result.output, result.output
    assert result.exit_code == 0, result.output
    return result


def test_each_row_of_a_drawn_lane_peaks_on_the_lane():
    straight = lane((410.0, 589.0), (820.0, 0.0))  # image pixels, bottom first
    maps = draw_lane_maps((straight,), (0.8,), MAPS, GEOMETRY, 0.5)
    channel = maps.probabilities[1]  # left of the centre at the bottom: the ego-left channel
    assert maps.existence.tolist() == [0.0, 1.0, 0.0, 0.0]
    assert maps.lanes == (straight,)
    for row in range(0, 288, 7):
        top, bottom = GEOMETRY.image_to_map(straight.points[::-1])  # the lane in map pixels
        expected = np.interp(row, [top[1], bottom[1]], [top[0], bottom[0]])
        assert abs(int(channel[row].argmax()) - expected) <= 0.5 + 1e-9
        assert channel[row].max() == round(0.8 * 255)
        assert np.count_nonzero(channel[row]) == 2 * RIDGE_HALF_WIDTH_PX + 1


def test_lanes_go_to_the_models_channels_by_side_and_distance():
    far_left, left, right, far_right, beyond = (
        lane((100, 589), (700, 250)), lane((600, 589), (780, 250)), lane((1000, 589), (860, 250)),
        lane((1500, 589), (950, 250)), lane((1630, 589), (1000, 250)))
    maps = draw_lane_maps((right, beyond, far_left, left, far_right), (1.0,) * 5, MAPS, GEOMETRY, 0.5)
    bottom = maps.probabilities[:, 287].argmax(axis=1) * 1640 / 800
    assert np.allclose(bottom, [100, 600, 1000, 1500], atol=6)  # `beyond` has no channel left
    assert len(maps.lanes) == 5  # but stays in the detector's own output


def test_culane_lane_files_with_scores(tmp_path):
    stem = tmp_path / "d" / "v.MP4" / "00000"
    stem.parent.mkdir(parents=True)
    stem.with_name("00000.lines.txt").write_text("600 589 780 250 \n1000 589 860 250 \n")
    stem.with_name("00000.scores.txt").write_text("0.5\n1\n")
    maps = load_maps(tmp_path, "d/v.MP4/00000.jpg", MAPS, GEOMETRY, 0.5, CULANE_LANES)
    assert maps.probabilities[1].max() == 128 and maps.probabilities[2].max() == 255
    stem.with_name("00000.scores.txt").write_text("0.5\n")
    with pytest.raises(InputError, match="1 scores for 2 lanes"):
        load_maps(tmp_path, "d/v.MP4/00000.jpg", MAPS, GEOMETRY, 0.5, CULANE_LANES)
    stem.with_name("00000.scores.txt").write_text("0.5\n1.5\n")
    with pytest.raises(InputError, match=r"00000.scores.txt:2: lane score '1.5' is not a number in \[0, 1\]"):
        load_maps(tmp_path, "d/v.MP4/00000.jpg", MAPS, GEOMETRY, 0.5, CULANE_LANES)


def test_tusimple_prediction_files(tmp_path):
    rows = list(range(160, 720, 10))
    record = {"raw_file": "clips/a/1.jpg", "lanes": [[400 + y // 4 for y in rows]], "h_samples": rows}
    (tmp_path / "predictions.json").write_text(json.dumps(record) + "\n")
    geometry = MapGeometry(1280, 720, 800, 288)
    maps = load_maps(tmp_path, "clips/a/1.jpg", MAPS, geometry, 0.5, TUSIMPLE_LANES)
    assert maps.existence[1] == 1.0 and len(maps.lanes) == 1
    # A frame without a line has no lanes (a detector's file may hold only labelled frames).
    assert load_maps(tmp_path, "clips/a/2.jpg", MAPS, geometry, 0.5, TUSIMPLE_LANES).lanes == ()
    (tmp_path / "predictions.json").write_text((json.dumps(record) + "\n") * 2)
    with pytest.raises(InputError, match="clips/a/1.jpg has lanes twice"):
        load_maps(tmp_path, "clips/a/1.jpg", MAPS, geometry, 0.5, TUSIMPLE_LANES)


def test_the_detector_row_is_the_saved_baseline_exactly_on_the_real_clip(real_clip_tree, tmp_path):
    data, maps = real_clip_tree
    first = tmp_path / "maps-run"
    invoke(["run", "--data-root", str(data), "--maps-root", str(maps), "--maps-format", "scnn-png",
            "--save-lanes", "--workers", "1", "--quiet", "--out", str(first)])
    second = tmp_path / "lanes-run"
    invoke(["run", "--data-root", str(data), "--maps-root", str(first / "lanes" / "baseline"),
            "--maps-format", "lanes", "--pft-ablation", "--workers", "1", "--quiet", "--out", str(second)])
    before = pd.read_csv(first / "official.csv")
    after = pd.read_csv(second / "official.csv")
    detector = after[after["method"] == "baseline"].reset_index(drop=True)
    pd.testing.assert_frame_equal(detector, before[before["method"] == "baseline"].reset_index(drop=True))
    accuracy = pd.read_csv(second / "accuracy.csv")
    assert {"roneld", "roneld-nopft"} <= set(accuracy["method"])
    assert accuracy[accuracy["method"] == "roneld"]["n_gt"].iloc[0] == 156


@pytest.mark.parametrize("dataset", ["culane", "tusimple"])
def test_synthetic_lane_files_run_end_to_end(dataset, tmp_path):
    make = synth_culane if dataset == "culane" else synth_tusimple
    made = make(tmp_path / "set", clips=2, frames=6 if dataset == "culane" else 20, seed=2, maps_format="lanes")
    out = tmp_path / "out"
    invoke(["run", "--dataset", dataset, "--data-root", str(made.data_root), "--maps-root", str(made.maps_root),
            "--maps-format", "lanes", "--workers", "1", "--quiet", "--set", "model=LaneDetector", "--out", str(out)])
    accuracy = pd.read_csv(out / "accuracy.csv")
    assert set(accuracy["method"]) == {"baseline", "roneld"}
    assert "LaneDetector + RONELD" in (out / "accuracy.md").read_text()
    again = make(tmp_path / "again", clips=2, frames=6 if dataset == "culane" else 20, seed=2, maps_format="lanes")
    files = sorted(p.relative_to(made.maps_root) for p in made.maps_root.rglob("*") if p.is_file())
    assert files and all((made.maps_root / f).read_bytes() == (again.maps_root / f).read_bytes() for f in files)


def test_lane_files_are_labelled_as_a_detectors_not_as_the_presets_model(tmp_path):
    # The CULane preset names SCNN: its lanes files ran as "SCNN" and "SCNN probability maps".
    made = synth_culane(tmp_path / "set", clips=2, frames=4, seed=2, maps_format="lanes")
    args = ["run", "--data-root", str(made.data_root), "--maps-root", str(made.maps_root), "--maps-format", "lanes",
            "--workers", "1", "--quiet"]
    invoke([*args, "--out", str(tmp_path / "unnamed")])
    text = (tmp_path / "unnamed" / "accuracy.md").read_text()
    assert text.startswith("# Accuracy on CULane, detector's lanes drawn into maps\n")
    assert "| detector | detector + RONELD |" in text and "SCNN" not in text and "probability" not in text
    assert 'model = "detector"' in (tmp_path / "unnamed" / "config.toml").read_text()
    invoke([*args, "--set", "model=CLRNet", "--out", str(tmp_path / "named")])
    assert "| CLRNet | CLRNet + RONELD |" in (tmp_path / "named" / "accuracy.md").read_text()
    invoke(["run", "--config", str(tmp_path / "unnamed" / "config.toml"), "--workers", "1", "--quiet", "--out",
            str(tmp_path / "again")])
    assert (tmp_path / "again" / "accuracy.md").read_text() == text
    # the same through --set, and through the preset named; a model the user's own file names is kept
    invoke([*args[:5], "--set", "maps.format=lanes", *args[7:], "--config", "scnn-culane", "--out",
            str(tmp_path / "by-set")])
    assert (tmp_path / "by-set" / "accuracy.md").read_text() == text
    own = tmp_path / "own.toml"
    own.write_text('model = "ERFNet"\n[dataset]\nname = "culane"\n')
    invoke([*args, "--config", str(own), "--out", str(tmp_path / "own")])
    assert "| ERFNet | ERFNet + RONELD |" in (tmp_path / "own" / "accuracy.md").read_text()
    for empty in ("model=", "model= "):
        result = CliRunner().invoke(main, [*args, "--set", empty, "--out", str(tmp_path / "empty")])
        assert result.exit_code == 2 and "model is empty" in result.output, result.output


def test_compare_does_not_average_two_unnamed_detectors_as_seeds_of_one(tmp_path):
    # Both lane-file runs were labelled "detector" by default, and compare averaged them as n = 2.
    made = synth_culane(tmp_path / "set", clips=2, frames=4, seed=2, maps_format="lanes")
    runs = []
    for name in ("a", "b"):
        invoke(["run", "--data-root", str(made.data_root), "--maps-root", str(made.maps_root), "--maps-format",
                "lanes", "--workers", "1", "--quiet", "--no-timings", "--out", str(tmp_path / name)])
        runs.append(str(tmp_path / name))
    result = CliRunner().invoke(main, ["compare", *runs, "--out", str(tmp_path / "c")])
    assert result.exit_code == 2 and result.output.count("\n") == 1, result.output
    assert "both are labelled 'detector'" in result.output and "--label RUN=NAME" in result.output
    assert not (tmp_path / "c").exists()
    invoke(["compare", *runs, "--label", f"{runs[0]}=CLRNet", "--label", f"{runs[1]}=LaneATT", "--out",
            str(tmp_path / "named")])
    assert "n = 2" not in (tmp_path / "named" / "table_accuracy.md").read_text()
    # Named as one model's seeds, the two are still one result twice (the same lane files): refused.
    result = CliRunner().invoke(main, ["compare", *runs, "--label", f"{runs[0]}=CLRNet", "--label",
                                       f"{runs[1]}=CLRNet", "--out", str(tmp_path / "seeds")])
    assert result.exit_code == 2 and result.output.count("\n") == 1, result.output
    assert "as two runs of 'CLRNet': every IoU of every method is the same in both" in result.output
    assert not (tmp_path / "seeds").exists()


def test_another_benchmarks_lane_files_are_named_with_the_dataset_that_reads_them(tmp_path):
    # Both said only "maps missing", TuSimple's listing predictions.json once per frame.
    culane = synth_culane(tmp_path / "c", clips=2, frames=3, seed=2, maps_format="lanes")
    tusimple = synth_tusimple(tmp_path / "t", clips=2, frames=20, seed=2, maps_format="lanes")

    def refused(*args):
        result = CliRunner().invoke(main, ["run", *args, "--maps-format", "lanes", "--workers", "1", "--quiet",
                                           "--out", str(tmp_path / "out")])
        assert result.exit_code == 2 and result.output.count("\n") == 1, result.output
        return result.output

    said = refused("--data-root", str(culane.data_root), "--maps-root", str(tusimple.maps_root))
    assert said.rstrip().endswith("; it holds predictions.json, lane files in the format --dataset tusimple "
                                  "reads a detector's lanes in")
    said = refused("--dataset", "tusimple", "--data-root", str(tusimple.data_root), "--maps-root",
                   str(culane.maps_root))
    assert said.count("predictions.json") == 1 and " more" not in said
    assert ".lines.txt, lane files in the format --dataset culane" in said
    deep = folder = tmp_path / "deep"  # os.walk raised RecursionError on the hint's search
    for _ in range(1200):  # one level at a time: os.makedirs recurses too
        folder = folder / "a"
        folder.mkdir(parents=True)
    try:
        said = refused("--dataset", "tusimple", "--data-root", str(tusimple.data_root), "--maps-root", str(deep))
        assert "maps missing" in said and "it holds" not in said
    finally:
        while folder != deep.parent:  # bottom up: pytest's own clean-up (shutil.rmtree) recurses as deep
            folder.rmdir()
            folder = folder.parent


def test_a_tusimple_prediction_file_for_other_paths_is_refused(tmp_path):
    made = synth_tusimple(tmp_path / "set", clips=2, frames=20, seed=2, maps_format="lanes")
    predictions = made.maps_root / "predictions.json"
    predictions.write_text(predictions.read_text().replace('"raw_file": "clips/', '"raw_file": "test_set/clips/'))
    result = CliRunner().invoke(main, ["run", "--dataset", "tusimple", "--data-root", str(made.data_root),
                                       "--maps-root", str(made.maps_root), "--maps-format", "lanes", "--quiet",
                                       "--workers", "1", "--out", str(tmp_path / "out")])
    assert result.exit_code == 2 and "no line for any of the 2 labelled frames" in result.output, result.output
    assert "its first line is for 'test_set/clips/" in result.output


@pytest.mark.parametrize("line", ['{"raw_file": "a/1.jpg", "lanes": [[' + "9" * 5001 + ']], "h_samples": [1]}',
                                  "[" * 100_000])
def test_json_no_parser_can_hold_is_one_error(tmp_path, line):
    (tmp_path / "predictions.json").write_text(line + "\n")
    with pytest.raises(InputError, match="predictions.json:1: not JSON this tool can read"):
        load_maps(tmp_path, "a/1.jpg", MAPS, MapGeometry(1280, 720, 800, 288), 0.5, TUSIMPLE_LANES)
