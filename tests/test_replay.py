"""`roneld-eval replay` (issue 50): one recorded clip through RoneldTracker.update, its accuracy the
run's on the same clip (the same metric modules), an MP4 of the drive, and bad input as one line."""

from __future__ import annotations

import csv
import os
import shutil
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
from click.testing import CliRunner
from conftest import REPO, env_importing

from roneld_eval import api
from roneld_eval.cli import main

FIXTURE_MAPS = REPO / "roneld_eval" / "_fixture" / "culane" / "maps"


def invoke(*args: str):
    return CliRunner().invoke(main, [str(arg) for arg in args])


def accuracy_rows(path: Path) -> list[tuple[str, str, int, int]]:
    with open(path, newline="") as file:
        return [(row["method"], row["threshold"], int(row["n_tp"]), int(row["n_gt"])) for row in csv.DictReader(file)]


def test_the_real_clip_scores_as_run_scores_it(real_clip_tree, tmp_path):
    data, maps = real_clip_tree
    common = ["--data-root", data, "--maps-root", maps, "--maps-format", "scnn-png"]
    ran = invoke("run", *common, "--pft-ablation", "--quiet", "--workers", "1", "--out", tmp_path / "run")
    assert ran.exit_code == 0, ran.output
    expected = accuracy_rows(tmp_path / "run" / "accuracy.csv")
    from roneld_eval.config import EvalConfig
    from roneld_eval.replay import replay_clip

    config = EvalConfig.preset("scnn-culane").with_overrides(**{
        "dataset.data_root": str(data), "maps.root": str(maps), "maps.format": "scnn-png"})
    for pft, method in ((True, "roneld"), (False, "roneld-nopft")):
        result = replay_clip(config, pft=pft)
        assert result.frames == result.scored_frames == 90 and result.latency.frames == 90
        assert result.accuracy is not None
        replayed = [(row.method, row.threshold, row.n_tp, row.n_gt) for row in result.accuracy.itertuples()]
        assert replayed == [row for row in expected if row[0] == method]
    shown = invoke("replay", *common, "--video", tmp_path / "drive.mp4", "--quiet")
    assert shown.exit_code == 0, shown.output
    assert "155/156 = 0.994 at IoU > 0.30" in shown.output and "p50" in shown.output
    video = cv2.VideoCapture(str(tmp_path / "drive.mp4"))
    assert int(video.get(cv2.CAP_PROP_FRAME_COUNT)) == 90 and int(video.get(cv2.CAP_PROP_FRAME_WIDTH)) == 1000
    video.release()
    assert sorted(os.listdir(tmp_path)) == ["data", "drive.mp4", "maps", "run"]  # nothing else written


def test_a_folder_of_maps_with_its_camera_images(real_clip, tmp_path):
    result = invoke("replay", "--maps-root", real_clip, "--maps-format", "scnn-png", "--images", real_clip,
                    "--video", tmp_path / "drive.mp4", "--quiet")
    assert result.exit_code == 0, result.output
    video = cv2.VideoCapture(str(tmp_path / "drive.mp4"))
    pictures = [video.read()[1] for _ in range(2)]
    video.release()
    assert pictures[0][:300].std() > 40  # 00000.jpg
    assert np.median(pictures[1][:300]) < 60  # 00030 has no image: a blank canvas


def test_a_folder_of_maps_is_one_clip_without_ground_truth(tmp_path):
    clip = next(path for path in sorted(FIXTURE_MAPS.rglob("*.MP4")) if path.is_dir())
    folder = tmp_path / "clip"
    shutil.copytree(clip, folder)
    (folder / "notes.txt").write_text("not a frame")
    result = invoke("replay", "--maps-root", folder, "--maps-format", "npz", "--video", tmp_path / "clip.mp4")
    assert result.exit_code == 0, result.output
    frames = len(list(folder.glob("*.npz")))
    assert f"replayed {frames} frames of clip with roneld (800x288 maps)" in result.output
    assert "accuracy: no ground truth" in result.output
    video = cv2.VideoCapture(str(tmp_path / "clip.mp4"))
    assert int(video.get(cv2.CAP_PROP_FRAME_COUNT)) == frames
    ok, picture = video.read()
    video.release()
    assert ok and np.median(picture[:300]) < 60  # a blank (dark) canvas: no camera images here


def test_frames_of_a_folder_come_in_number_order(tmp_path):
    from roneld_eval.config import MapsConfig
    from roneld_eval.maps import frames_in_folder

    for name in ("frame_10", "frame_2", "frame_1", "a"):
        np.save(tmp_path / f"{name}.npy", np.zeros((4, 2, 2), np.uint8))
    assert frames_in_folder(tmp_path, MapsConfig()) == ["a.jpg", "frame_1.jpg", "frame_2.jpg", "frame_10.jpg"]


def test_a_synthetic_vil100_video_of_lane_files(tmp_path):
    made = invoke("synth", "--dataset", "vil100", "--out", tmp_path / "set", "--clips", "2", "--frames", "6",
                  "--maps-format", "lanes")
    assert made.exit_code == 0, made.output
    data, maps = tmp_path / "set" / "data", tmp_path / "set" / "maps"
    several = invoke("replay", "--dataset", "vil100", "--data-root", data, "--maps-root", maps)
    assert several.exit_code == 2 and "the dataset holds 2 clips: choose one with --clip" in several.output
    clip = sorted(path.name for path in (data / "anno_txt").iterdir())[1]
    result = invoke("replay", "--dataset", "vil100", "--data-root", data, "--maps-root", maps, "--clip", clip)
    assert result.exit_code == 0, result.output
    assert "over 6 labelled frames" in result.output
    folder = invoke("replay", "--dataset", "vil100", "--maps-root", maps / clip, "--maps-format", "lanes",
                    "--image-size", "1280x720")
    assert folder.exit_code == 0, folder.output


# ---- bad input: one line, exit 2, nothing written ---------------------------------------------------


def one_line(result, *expected: str) -> None:
    assert result.exit_code == 2, result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), result.output
    for text in expected:
        assert text in lines[0], lines[0]


def test_bad_input_is_one_line(tmp_path):
    empty = tmp_path / "empty"
    empty.mkdir()
    one_line(invoke("replay", "--maps-root", tmp_path / "nowhere"), f"error: {tmp_path / 'nowhere'}: no such folder")
    one_line(invoke("replay", "--maps-root", empty), f"{empty}: holds no npy maps (files named <frame>.npy)")
    (empty / "clip_b").mkdir()  # a dataset's maps root given for one clip's: a first-time user got no hint
    (empty / "clip_a").mkdir()
    one_line(invoke("replay", "--maps-root", empty), "(files named <frame>.npy): it holds folders (e.g. clip_a), as "
             "a dataset's maps root does: give one clip's folder, or the dataset with --data-root and --clip")
    (empty / "00000.exist.txt").write_text("1 1 1 1\n")
    one_line(invoke("replay", "--maps-root", empty), "it holds 1 .exist.txt files, use --maps-format scnn-png")
    one_line(invoke("replay", "--maps-root", empty, "--image-size", "big"), "'big' is not WIDTHxHEIGHT")
    one_line(invoke("replay", "--maps-root", empty, "--clip", "x"), "--clip chooses a clip of a dataset")
    data, maps = api.fixture_roots("culane")
    near = "driver_100_30frame/05181432_0203.MP"
    one_line(invoke("replay", "--data-root", data, "--maps-root", maps, "--clip", near),
             "no clip 'driver_100_30frame/05181432_0203.MP' in the dataset (did you mean "
             "driver_100_30frame/05181432_0203.MP4?)")
    one_line(invoke("replay", "--data-root", data, "--maps-root", maps, "--maps-format", "npz", "--clip",
                    "driver_100_30frame/05181432_0203.MP4", "--video", tmp_path / "drive.avi"),
             "the video is an MP4: name it <something>.mp4")


def test_a_bad_frame_mid_clip_leaves_no_video(tmp_path):
    clip = next(path for path in sorted(FIXTURE_MAPS.rglob("*.MP4")) if path.is_dir())
    folder = tmp_path / "clip"
    shutil.copytree(clip, folder)
    frames = sorted(folder.glob("*.npz"))
    np.savez(frames[len(frames) // 2], probs=np.zeros((4, 288, 700), np.uint8))
    out = tmp_path / "out"
    out.mkdir()
    result = invoke("replay", "--maps-root", folder, "--maps-format", "npz", "--video", out / "drive.mp4")
    one_line(result, f"error: {frames[len(frames) // 2]}: maps of 700x288 differ from this clip's 800x288")
    assert os.listdir(out) == []


def test_the_command_in_a_process_prints_no_traceback(tmp_path):
    done = subprocess.run([sys.executable, "-m", "roneld_eval", "replay", "--maps-root", str(tmp_path)],
                          capture_output=True, text=True, env=env_importing(), timeout=120)
    assert done.returncode == 2 and done.stderr.strip() == f"error: {tmp_path}: holds no npy maps (files named " \
                                                         "<frame>.npy)", done.stderr


def test_what_an_independent_check_found_is_one_line_not_a_silent_result(tmp_path, monkeypatch):
    clip = next(path for path in sorted(FIXTURE_MAPS.rglob("*.MP4")) if path.is_dir())
    folder = tmp_path / "clip"
    shutil.copytree(clip, folder)
    frames = sorted(folder.glob("*.npz"))
    # A frame's maps that are a FIFO or a folder were passed over: fewer frames replayed, exit 0.
    frames[1].unlink()
    os.mkfifo(frames[1])
    one_line(invoke("replay", "--maps-root", folder, "--maps-format", "npz"),
             f"{frames[1]}: is not a regular file")
    frames[1].unlink()
    frames[1].mkdir()
    one_line(invoke("replay", "--maps-root", folder, "--maps-format", "npz"), f"{frames[1]}: is not a regular file")
    frames[1].rmdir()
    # --images that do not exist drew every frame on a blank canvas without a word.
    one_line(invoke("replay", "--maps-root", folder, "--maps-format", "npz", "--images", tmp_path / "none",
                    "--video", tmp_path / "v.mp4"), f"{tmp_path / 'none'}: no such folder of camera frames")
    assert not (tmp_path / "v.mp4").exists()
    # A video that cannot be written whole (a full disk: OpenCV's writer fails without a word) was
    # kept and announced, exit 0.
    real_write = cv2.VideoWriter.write

    def dropping(self, picture):  # the frames after the first never reach the file
        dropping.calls += 1
        if dropping.calls == 1:
            real_write(self, picture)

    dropping.calls = 0
    monkeypatch.setattr(cv2.VideoWriter, "write", dropping)
    one_line(invoke("replay", "--maps-root", folder, "--maps-format", "npz", "--video", tmp_path / "v.mp4"),
             f"{tmp_path / 'v.mp4'}: the video could not be written whole (1 of {len(frames) - 1} frames readable")
    assert not list(tmp_path.glob("*.mp4")) and not list(tmp_path.glob(".*.mp4"))


def test_a_dataset_clip_takes_a_list_and_is_named(real_clip, tmp_path):
    listed = tmp_path / "frames.txt"
    listed.write_text("".join(f"{path.name[:5]}.jpg\n" for path in sorted(real_clip.glob("*_1_avg.png"))))
    result = invoke("replay", "--data-root", real_clip, "--maps-root", real_clip, "--maps-format", "scnn-png",
                    "--list", listed, "--quiet")
    assert result.exit_code == 0, result.output
    assert f"replayed 90 frames of {real_clip.name} with roneld" in result.output
    assert "over 90 labelled frames" in result.output


def test_an_images_folder_without_the_frames_pictures_is_said_not_silent(tmp_path):
    clip = next(path for path in sorted(FIXTURE_MAPS.rglob("*.MP4")) if path.is_dir())
    frames = sorted(path.stem for path in clip.glob("*.npz"))
    images = tmp_path / "images"
    images.mkdir()
    cv2.imwrite(str(images / f"{frames[0]}.jpg"), np.full((590, 1640, 3), 200, np.uint8))
    result = invoke("replay", "--maps-root", clip, "--maps-format", "npz", "--images", images,
                    "--video", tmp_path / "clip.mp4", "--quiet")
    assert result.exit_code == 0, result.output
    assert (f"warning: --images has no picture of {len(frames) - 1} frames of {len(frames)} (first: "
            f"{frames[1]}") in result.output
    quiet = invoke("replay", "--maps-root", clip, "--maps-format", "npz", "--video", tmp_path / "again.mp4")
    assert quiet.exit_code == 0 and "warning" not in quiet.output  # no --images: a blank canvas is expected
