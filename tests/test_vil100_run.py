"""`run --dataset vil100`: each video drawn and scored at its own size, its official table equal
to `score vil100` on the run's own lanes (that scorer is the one checked against MMA-Net's C++
and RVLD's script, tests/test_vil100.py), the ego lanes' temporal metrics, `synth`, the layout's
errors, and the real ground truth where ../shared is present."""

from __future__ import annotations

import csv
import json
import shutil
from pathlib import Path

import pytest
from click.testing import CliRunner

from roneld_eval.cli import main
from roneld_eval.config import EvalConfig
from roneld_eval.geometry import MapGeometry
from roneld_eval.model import Frame

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data" / "vil100"


def invoke(*args: str):
    return CliRunner().invoke(main, list(args))


def rows(path: Path, *key: str) -> dict:
    with open(path, newline="") as file:
        return {tuple(row[k] for k in key): row for row in csv.DictReader(file)}


@pytest.fixture(scope="module")
def synthetic(tmp_path_factory):
    """Three videos (1920x1080, 960x480, 1280x720) of 12 frames as a detector's lane files, run
    with the ablation and its lanes saved."""
    base = tmp_path_factory.mktemp("vil100run")
    assert invoke("synth", "--dataset", "vil100", "--out", str(base / "set"), "--clips", "3", "--frames", "12",
                  "--maps-format", "lanes").exit_code == 0
    result = invoke("run", "--dataset", "vil100", "--data-root", str(base / "set" / "data"), "--maps-root",
                    str(base / "set" / "maps"), "--pft-ablation", "--save-lanes", "--workers", "2",
                    "--out", str(base / "out"), "--quiet")
    assert result.exit_code == 0, result.output
    return base


def test_synth_writes_videos_of_several_sizes_deterministically(synthetic, tmp_path):
    data = synthetic / "set" / "data"
    sizes = json.loads((data / "sizes.json").read_text())
    assert sorted(tuple(size.values()) for size in sizes.values()) == [(960, 480), (1280, 720), (1920, 1080)]
    assert sorted(p.name for p in (data / "anno_txt").iterdir()) == sorted(sizes)
    frames = sorted(p.name for p in (data / "anno_txt" / next(iter(sizes))).iterdir())
    assert frames[:3] == ["00000.lines.txt", "00003.lines.txt", "00006.lines.txt"]  # every third video frame
    assert invoke("synth", "--dataset", "vil100", "--out", str(tmp_path / "again"), "--clips", "3", "--frames",
                  "12", "--maps-format", "lanes").exit_code == 0
    for path in sorted((synthetic / "set").rglob("*.txt")):
        assert (tmp_path / "again" / path.relative_to(synthetic / "set")).read_bytes() == path.read_bytes()


def test_the_official_table_equals_score_vil100_on_the_runs_own_lanes(synthetic):
    out = synthetic / "out"
    scored = synthetic / "scored"
    result = invoke("score", "vil100", "--labels", str(synthetic / "set" / "data" / "anno_txt"), "--pred-root",
                    str(out / "lanes"), "--sizes", str(synthetic / "set" / "data" / "sizes.json"),
                    "--out", str(scored), "--quiet")
    assert result.exit_code == 0, result.output
    run = rows(out / "official.csv", "method", "category", "threshold")
    official = rows(scored / "official.csv", "method", "category", "threshold")
    temporal = rows(scored / "temporal.csv", "method", "category", "tau")
    assert {key[0] for key in official} == {"baseline", "roneld", "roneld-nopft"}
    assert set(official) == {key for key in run if key[1] != "ego"}
    for key, expected in official.items():
        for column in ("tp", "fp", "fn", "precision", "recall", "f1", "miou", "sequences"):
            assert run[key][column] == expected[column], (key, column)
        for column in ("pairs", "stable", "jump", "missing", "rs", "rj", "rm"):
            assert run[key][column] == temporal[key][column], (key, column)


def test_the_ego_rows_pair_the_ground_truths_ego_lanes_with_the_active_lanes(synthetic):
    run = rows(synthetic / "out" / "official.csv", "method", "category", "threshold")
    for method in ("baseline", "roneld", "roneld-nopft"):
        ego, every = run[(method, "ego", "0.50")], run[(method, "all", "0.50")]
        assert int(ego["tp"]) + int(ego["fn"]) <= 2 * 36  # at most two ego lanes in each of 36 frames
        assert int(ego["pairs"]) <= int(every["pairs"])
    # RONELD outputs its two active lanes only: over every lane it misses the others, not over the ego lanes
    assert int(run[("roneld", "ego", "0.50")]["fn"]) < int(run[("roneld", "all", "0.50")]["fn"])


def test_each_video_is_drawn_at_its_own_size(synthetic):
    summary = json.loads((synthetic / "out" / "summary.json").read_text())
    assert summary["geometry"]["frame_sizes"] == [[1920, 1080], [1280, 720], [960, 480]]
    report = (synthetic / "out" / "report.html").read_text()
    assert "at each video&#x27;s own size (1920x1080, 1280x720, 960x480)" in report or \
        "at each video's own size (1920x1080, 1280x720, 960x480)" in report


def test_lanes_are_drawn_into_maps_at_their_videos_size(synthetic, tmp_path):
    # The ground truth as a detector's lanes: RONELD finds the same ego lanes on every video. Drawn
    # at the reference size instead, a 960x480 video's lanes all lie left of the centre (IoU 0.27).
    import pandas as pd

    data = synthetic / "set" / "data"
    result = invoke("run", "--dataset", "vil100", "--data-root", str(data), "--maps-root", str(data / "anno_txt"),
                    "--out", str(tmp_path / "out"), "--quiet")
    assert result.exit_code == 0, result.output
    frames = pd.read_csv(tmp_path / "out" / "per_frame.csv")
    means = frames.assign(video=frames["frame"].str.split("/").str[0]).groupby(["video", "method"])["iou"].mean()
    for video in means.index.get_level_values("video").unique():
        # 16 px ground truth inside 30 px predictions: IoU 16/30 at best (the paper's protocol)
        assert 0.5 < means[(video, "baseline")] < 0.55
        assert abs(means[(video, "roneld")] - means[(video, "baseline")]) < 0.03, video


def test_a_frames_geometry_scales_the_crop_with_its_height():
    geometry = MapGeometry(1920, 1080, 800, 288, crop_top_px=540, crop_bottom_px=1080)
    small = geometry.at_image_size(960, 480)
    assert (small.image_width, small.image_height, small.crop_top_px, small.crop_bottom_px) == (960, 480, 240, 480)
    assert geometry.at_image_size(1920, 1080) is geometry
    config = EvalConfig.preset("lanes-vil100")
    assert config.geometry_of(Frame("a/00000.jpg")) == config.geometry
    assert config.geometry_of(Frame("a/00000.jpg", image_size=(672, 378))).image_size == (672, 378)


def test_resume_of_a_finished_run_gives_the_same_table(synthetic, tmp_path):
    out = tmp_path / "out"
    shutil.copytree(synthetic / "out", out)
    result = invoke("run", "--dataset", "vil100", "--data-root", str(synthetic / "set" / "data"), "--maps-root",
                    str(synthetic / "set" / "maps"), "--pft-ablation", "--save-lanes", "--workers", "1",
                    "--out", str(out), "--resume", "--quiet")
    assert result.exit_code == 0, result.output
    assert (out / "official.csv").read_bytes() == (synthetic / "out" / "official.csv").read_bytes()


def test_compare_shows_the_official_and_temporal_scores(synthetic, tmp_path):
    other = tmp_path / "second"
    shutil.copytree(synthetic / "out", other)
    # named: two runs the preset leaves as "detector" are not taken for seeds of one model (and a
    # copy is one result twice: as two models, not as two seeds of one)
    result = invoke("compare", str(synthetic / "out"), str(other), "--label", f"{synthetic / 'out'}=LaneATT",
                    "--label", f"{other}=CLRNet", "--out", str(tmp_path / "cmp"), "--quiet")
    assert result.exit_code == 0, result.output
    table = (tmp_path / "cmp" / "table_official.md").read_text()
    run = rows(synthetic / "out" / "official.csv", "method", "category", "threshold")
    rs = 100 * float(run[("roneld", "ego", "0.50")]["rs"])
    for model in ("LaneATT", "CLRNet"):
        line = next(line for line in table.splitlines() if line.startswith(f"| {model} + RONELD | ego | "))
        assert f"| {rs:.2f} |" in line, line


def _layout(tmp_path: Path, synthetic: Path) -> Path:
    root = tmp_path / "root"
    shutil.copytree(synthetic / "set" / "data", root)
    return root


@pytest.mark.parametrize("change, expected", [
    (lambda root: shutil.rmtree(root / "anno_txt"), ("anno_txt", "ground-truth folder not found")),
    (lambda root: (root / "sizes.json").unlink(), ("no image sizes", "JPEGImages/, Json/ or sizes.json")),
    (lambda root: (root / "sizes.json").write_text('{"x": [1, 2]}'), ("sizes.json", "no size for sequence")),
    (lambda root: next((root / "anno_txt").rglob("00003.lines.txt")).write_text("5000 5000 6000 6000\n"),
     ("00003.lines.txt", "lies far outside")),
])
def test_a_bad_layout_is_one_line_naming_the_file(synthetic, tmp_path, change, expected):
    root = _layout(tmp_path, synthetic)
    change(root)
    result = invoke("run", "--dataset", "vil100", "--data-root", str(root), "--maps-root",
                    str(synthetic / "set" / "maps"), "--out", str(tmp_path / "out"), "--quiet")
    assert result.exit_code == 2, result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and "Traceback" not in result.output
    for text in expected:
        assert text in lines[0], lines[0]
    assert not (tmp_path / "out").exists()


def test_a_listed_frame_without_ground_truth_stops_or_is_skipped(synthetic, tmp_path):
    root = _layout(tmp_path, synthetic)
    (root / "data").mkdir()
    listed = sorted(str(p.relative_to(root / "anno_txt"))[:-len(".lines.txt")]
                    for p in (root / "anno_txt").rglob("*.lines.txt"))
    (root / "data" / "test.txt").write_text("".join(f"/JPEGImages/{entry}.jpg\n" for entry in listed))
    missing = next((root / "anno_txt").rglob("00006.lines.txt"))
    missing.unlink()
    args = ["run", "--dataset", "vil100", "--data-root", str(root), "--maps-root", str(synthetic / "set" / "maps"),
            "--quiet"]
    result = invoke(*args, "--out", str(tmp_path / "out"))
    assert result.exit_code == 2 and str(missing) in result.output and "ground truth not found" in result.output
    result = invoke(*args, "--out", str(tmp_path / "skipped"), "--on-error", "skip")
    assert result.exit_code == 0, result.output
    summary = json.loads((tmp_path / "skipped" / "summary.json").read_text())
    assert summary["counts"]["frames"] == 35 and any(str(missing) in line for line in summary["skipped"])


@pytest.mark.skipif(not SHARED.is_dir(), reason="needs ../shared/data/vil100")
def test_the_real_ground_truth_as_a_detectors_lanes(tmp_path):
    # The real layout: MMA-Net's anno_txt and the dataset's list; sizes of the 20 test videos.
    root = tmp_path / "vil100"
    root.mkdir()
    (root / "anno_txt").symlink_to(SHARED / "anno_txt")
    (root / "data").mkdir()
    (root / "data" / "test.txt").write_text((SHARED / "test.txt").read_text())
    shutil.copy(SHARED / "test_sizes.json", root / "sizes.json")
    result = invoke("run", "--dataset", "vil100", "--data-root", str(root), "--maps-root", str(SHARED / "anno_txt"),
                    "--limit", "3", "--pft-ablation", "--out", str(tmp_path / "out"), "--quiet")
    assert result.exit_code == 0, result.output
    run = rows(tmp_path / "out" / "official.csv", "method", "category", "threshold")
    for threshold in ("0.50", "0.80"):
        baseline = run[("baseline", "all", threshold)]  # the detector's lanes are the ground truth
        assert (baseline["fp"], baseline["fn"], baseline["f1"], baseline["miou"]) == ("0", "0", "1.0", "1.0")
        assert baseline["rs"] == "1.0" and int(baseline["pairs"]) > 0
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["counts"]["frames"] == 300
    assert summary["geometry"]["frame_sizes"] == [[1920, 1080], [1280, 720], [960, 480]]


def test_compare_refuses_runs_that_scored_a_video_at_another_size(synthetic, tmp_path):
    data = tmp_path / "data"
    shutil.copytree(synthetic / "set" / "data", data)
    sizes = json.loads((data / "sizes.json").read_text())
    small = next(name for name, size in sizes.items() if size["width"] == 960)
    sizes[small] = {"width": 1280, "height": 640}
    (data / "sizes.json").write_text(json.dumps(sizes))
    result = invoke("run", "--dataset", "vil100", "--data-root", str(data), "--maps-root",
                    str(synthetic / "set" / "maps"), "--pft-ablation", "--out", str(tmp_path / "other"), "--quiet")
    assert result.exit_code == 0, result.output
    result = invoke("compare", str(synthetic / "out"), str(tmp_path / "other"), "--out", str(tmp_path / "c"))
    assert result.exit_code == 2
    assert f"at different frame sizes (clip {small}: 960x480 and 1280x640)" in result.output, result.output


def test_a_root_one_level_off_gets_a_hint(synthetic, tmp_path):
    data = synthetic / "set" / "data"
    result = invoke("run", "--dataset", "vil100", "--data-root", str(data / "anno_txt"), "--maps-root",
                    str(synthetic / "set" / "maps"), "--out", str(tmp_path / "o"), "--quiet")
    assert result.exit_code == 2 and "looks like the anno_txt folder itself" in result.output
    result = invoke("score", "vil100", "--labels", str(data), "--pred-root", str(synthetic / "out" / "lanes"),
                    "--sizes", str(data / "sizes.json"))
    assert result.exit_code == 2 and f"did you mean {data / 'anno_txt'}?" in result.output
    npy = tmp_path / "npy"
    assert invoke("synth", "--dataset", "vil100", "--out", str(npy), "--clips", "1", "--frames", "2").exit_code == 0
    result = invoke("run", "--dataset", "vil100", "--data-root", str(npy / "data"), "--maps-root", str(npy / "maps"),
                    "--out", str(tmp_path / "o2"), "--quiet")  # the preset reads lane files; synth wrote .npy
    assert result.exit_code == 2 and "(found 00000.npy: use --maps-format npy)" in result.output


def test_the_geometry_line_names_a_crop_scaled_with_each_frame():
    from roneld_eval.geometry import EffectiveGeometry

    sizes = ((1920, 1080), (960, 480))
    whole = EffectiveGeometry(1920, 1080, 800, 288, 0, 1080, False, 16, 30, 30, 0.5, sizes)
    assert "over the whole of each frame at its own size (1920x1080, 960x480)" in whole.describe()
    cropped = EffectiveGeometry(1920, 1080, 800, 288, 540, 1080, False, 16, 30, 30, 0.5, sizes)
    assert "over image rows 540..1079 of 1920x1080, scaled with the height of each frame" in cropped.describe()


def test_maps_of_another_size_in_one_clip_are_a_note_not_a_skip(tmp_path):
    import numpy as np

    assert invoke("synth", "--dataset", "vil100", "--out", str(tmp_path / "set"), "--clips", "2", "--frames",
                  "3").exit_code == 0
    first = sorted((tmp_path / "set" / "maps").iterdir())[0]
    for path in first.glob("*.npy"):
        np.save(path, np.load(path)[:, ::2, ::2])  # 400x144: the same shape, rescaled by its own clip
    result = CliRunner().invoke(main, [
        "run", "--dataset", "vil100", "--data-root", str(tmp_path / "set" / "data"), "--maps-root",
        str(tmp_path / "set" / "maps"), "--maps-format", "npy", "--out", str(tmp_path / "out"), "--quiet"])
    assert result.exit_code == 0, result.output
    assert "note: maps differ in size between clips" in result.stderr and "skipped" not in result.stderr
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["skipped"] == [] and summary["notes"][0].startswith("maps differ in size between clips")
