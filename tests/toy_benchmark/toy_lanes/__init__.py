"""A toy benchmark, as a third party's package ships one: `pip install tests/toy_benchmark` (its
pyproject.toml registers it under `roneld_eval.benchmarks`) and `--dataset toy` exists. The tests
use it without installing it: tests/toy_benchmark also holds a `toy_lanes-0.dist-info` saying the
same, so that putting the folder on PYTHONPATH registers it too.

Its layout: DATA/frames.txt lists `<clip>/<frame>.jpg`, each labelled frame's lanes lie in
`DATA/<clip>/<frame>.lanes.txt` (CULane's .lines.txt format), 1000x500 frames. Its "official"
score counts lanes: per method the frames, ground-truth and predicted lanes, and (a clip-level
metric, through `end_clip`) the clips in which the method predicted as many lanes as there were.
"""

from __future__ import annotations

import posixpath
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from roneld_eval.kit import (Camera, Clip, Dataset, Frame, InputError, LaneFile, LinesPerFrame, Option, ScoreCommand,
                             SynthResult, channel_lanes, clip_style, command_of, format_lines_txt, read_lines_txt,
                             render_maps, scene_sequence, write_maps)

WIDTH, HEIGHT = 1000, 500
CAMERA = Camera(WIDTH, HEIGHT, vanish_y=(200, 230), lane_width_px=(500, 600), top_margin_px=(10, 30))


@dataclass(frozen=True)
class ToyRecord:
    n_gt: int
    n_pred: int

    def to_json(self) -> Any:
        return {"toy": [self.n_gt, self.n_pred]}


class ToyTally:
    def __init__(self, methods):
        self.sums = {method: [0, 0, 0, 0, 0] for method in methods}  # frames, gt, pred, clips, exact clips
        self.clip_exact = {method: True for method in methods}

    def add(self, method, relpath, record):
        sums = self.sums[method]
        sums[0] += 1
        sums[1] += record.n_gt
        sums[2] += record.n_pred
        self.clip_exact[method] &= record.n_gt == record.n_pred

    def end_clip(self, clip_id):
        for method, sums in self.sums.items():
            sums[3] += 1
            sums[4] += self.clip_exact[method]
            self.clip_exact[method] = True

    def table(self):
        import pandas as pd

        return pd.DataFrame([(method, *sums) for method, sums in self.sums.items()],
                            columns=["method", "frames", "gt_lanes", "pred_lanes", "clips", "exact_clips"])


def _labels(root: Path, relpath: str) -> Path:
    return root / f"{posixpath.splitext(relpath)[0]}.lanes.txt"


class ToyBenchmark:
    name = "toy"
    display_name = "ToyLanes"
    image_size = (WIDTH, HEIGHT)
    default_preset = str(Path(__file__).with_name("toy.toml"))
    frames_per_clip = 6
    fixture = None
    kernel_groups: tuple[str, ...] = ()
    missing_maps_hint = ""
    detector_lanes = LinesPerFrame(suffix=".lanes.txt")  # as lane_file writes them

    def category_panel(self, official, protocol):
        return None  # its datasets have no categories

    official_columns = {"method": "text", "frames": "count", "gt_lanes": "count", "pred_lanes": "count",
                        "clips": "count", "exact_clips": "count"}
    official_optional: dict[str, str] = {}
    official_key = ("method",)

    def read(self, root, list_file, limit, errors, labels):
        listing = Path(list_file) if list_file is not None else root / "frames.txt"
        if not listing.is_file():
            raise InputError(listing, "frame list not found")
        by_clip: dict[str, list[str]] = {}
        for line in listing.read_text().split():
            by_clip.setdefault(posixpath.dirname(line), []).append(line)
        clips = []
        for clip_id, relpaths in list(by_clip.items())[:limit]:
            frames = tuple(Frame(relpath, read_lines_txt(_labels(root, relpath), missing_ok=False))
                           for relpath in sorted(relpaths))
            clips.append(Clip(clip_id, frames))
        return Dataset(self.name, root, WIDTH, HEIGHT, tuple(clips), source_file=listing)

    def with_labels(self, clip, root, errors):
        return clip

    def label_paths(self, clip, data_root, label_file):
        return [] if data_root is None else [_labels(data_root, frame.relpath) for frame in clip.frames]

    def prepare(self, frame, config):
        return len(frame.lanes)

    def score(self, prepared, prediction, config):
        return ToyRecord(prepared, len(prediction.lanes))

    def tally(self, methods, dataset, config):
        return ToyTally(methods)

    def decode(self, value):
        if not isinstance(value, dict) or set(value) != {"toy"}:
            raise TypeError("not a toy record")
        n_gt, n_pred = value["toy"]
        return ToyRecord(int(n_gt), int(n_pred))

    def lane_file(self, method, frame, lanes):
        return LaneFile(f"{method}/{frame.stem}.lanes.txt", format_lines_txt(lanes))

    def synthesize(self, out, clips, frames, seed, maps_format, progress):
        data, maps_root = out / "data", out / "maps"
        listing = []
        for index in range(clips):
            rng = np.random.default_rng([seed, index])
            style, _ = clip_style(index, rng, frames)
            for k, scene in enumerate(scene_sequence(CAMERA, frames, style, rng, frames_apart=10)):
                relpath = f"seq{index:02d}/{k:03d}.jpg"
                ys = np.arange(scene.height - 1, scene.top_y, -10.0)
                text = "".join(" ".join(f"{x:.1f} {y:.0f}" for x, y in zip(scene.boundary_x(lat, ys), ys)) + "\n"
                               for _, lat in sorted(channel_lanes(scene).items()))
                path = _labels(data, relpath)
                path.parent.mkdir(parents=True, exist_ok=True)
                path.write_text(text)
                write_maps(maps_root / relpath[:-4], render_maps(scene, style, k, rng), maps_format)
                listing.append(relpath)
        (data / "frames.txt").write_text("\n".join(listing) + "\n")
        return SynthResult(data, maps_root, self.name, maps_format, clips, clips * frames)

    def scorer(self):  # what roneld_eval.score("toy", ...) calls
        return score_toy

    def score_command(self):
        return command_of(COMMAND, self.scorer())

    def official_protocol(self, protocol):
        return None

    def official_note(self, protocol):
        return "ToyLanes counts lanes: frames, ground-truth and predicted lanes, and clips predicted exactly."

    def check_official(self, path, table):
        if (table["exact_clips"].astype(int) > table["clips"].astype(int)).any():
            raise InputError(path, "more exact clips than clips")

    def official_comparison(self, groups):
        from roneld_eval.kit import EMPTY, Column, Grid, Stat, Text, all_found, method_name, ordered_methods

        rows = []
        for group in groups:
            for method in ordered_methods(group.methods):
                hits = [run.official[run.official["method"] == method] for run in group.runs]
                found = all_found([None if hit.empty else hit.iloc[0] for hit in hits])
                cell = EMPTY if found is None else Stat(tuple(float(f["pred_lanes"]) for f in found), decimals=0)
                rows.append((Text(method_name(method, group.label)), cell))
        return (Grid((Column("Method", ("Method",)),), (Column("Predicted lanes", ("Pred.",)),), tuple(rows)),
                "ToyLanes: predicted lanes per method.")


@dataclass(frozen=True)
class ToyCount:
    frames: int
    gt_lanes: int
    pred_lanes: int


def score_toy(data_root, pred_root):
    """Count a detector's lanes against ToyLanes' ground truth."""
    dataset = BENCHMARK.read(Path(data_root), None, None, None, True)
    n_gt = n_pred = 0
    for clip in dataset.clips:
        for frame in clip.frames:
            n_gt += len(frame.lanes)
            n_pred += len(read_lines_txt(_labels(Path(pred_root), frame.relpath)))
    return ToyCount(dataset.n_frames, n_gt, n_pred)


def _report(count, values, echo):
    echo(f"{count.frames} frames: {count.gt_lanes} ground-truth lanes, {count.pred_lanes} predicted")


COMMAND = ScoreCommand(
    "toy", "Count a detector's lanes against ToyLanes' ground truth.",
    options=(Option("--data-root", "ToyLanes root (frames.txt and the labels).", kind="path", required=True),
             Option("--pred-root", "Predicted .lanes.txt files mirroring the root.", kind="path", required=True)),
    positional=("data_root", "pred_root"), report=_report, progress=False)


BENCHMARK = ToyBenchmark()
