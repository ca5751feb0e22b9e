"""`score openlane`: predicted lane JSON files scored as OpenLane's 2D evaluator scores them
(OpenDriveLab/OpenLane 8a0ce6b, eval/LANE_evaluation/lane2d), both ways it can: lanes matched only
to lanes of their own category (its default) and matched whatever their category (`-k ARG`, which,
against its name, turns the category off: src/counter.cpp:93-110). Every threshold and both ways
in one pass over the ground truth; the IoU is the CULane evaluator's (same spline, drawing and
matching: metrics.lane_iou_f1), on a 1920x1280 canvas, lanes 30 px wide.
"""

from __future__ import annotations

import posixpath
from dataclasses import dataclass, replace
from functools import partial
from pathlib import Path
from typing import Callable

import numpy as np

from ...config import check_lane_width

from ...thresholds import Thresholds, parse_thresholds
from .reader import IMAGE_HEIGHT, IMAGE_WIDTH, OpenLaneLanes, every_labelled_frame, json_path, read_lanes, read_list
from ...errors import ConfigError
from ...metrics.lane_errors import (DiagnosisCollector, DiagnosisSettings, FrameDiagnoses, category_iou,
                                    diagnosis_part, diagnosis_settings, diagnoses_merged, kernel_groups,
                                    split_diagnosed)
from ...metrics.lane_iou_f1 import f_measure, matched_result, official_masks
from ...report.diagnosis import Diagnosed, write_diagnosis
from ...report.gallery import GalleryFrame
from ...output import Staging
from ...scoring import PlainTable, PredictionRoots, _taking, find_prediction_trees, listed_frames, scored_pieces
from ...shards import Merged, Sharding, given_options

DEFAULT_IOU = "0.3"  # evaluate.cpp:121 (its help() says 0.4)
LANE_WIDTH = 30  # evaluate.cpp:120 (its help() says 10)
MODES = ("same category", "any category")  # the evaluator's default, and with -k
COLUMNS = ("method", "matching", "threshold", "tp", "fp", "fn", "precision", "recall", "f1")
CHUNK_FRAMES = 200


@dataclass(frozen=True)
class OpenLaneScore:
    rows: PlainTable
    thresholds: Thresholds
    methods: tuple[str, ...]
    modes: tuple[str, ...]
    n_frames: int
    warnings: tuple[str, ...] = ()
    diagnosed: Diagnosed | None = None  # --diagnose: error types and every frame's counts


def _score_frames(args) -> np.ndarray | tuple[np.ndarray, FrameDiagnoses | None]:
    """(methods, modes, thresholds, 3): TP, FP, FN of one chunk of frames; with `diagnosis`, and
    the frames' error types (their method axis: each method's modes in turn)."""
    relpaths, labels, pred_roots, width, height, lane_width, modes, thresholds, diagnosis = args
    counts = np.zeros((len(pred_roots), len(modes), len(thresholds), 3), np.int64)
    categories_needed = MODES[0] in modes
    diagnosed = DiagnosisCollector(diagnosis, len(pred_roots) * len(modes))  # each method's modes in turn
    for relpath in relpaths:
        truth = read_lanes(json_path(labels, relpath), categories_needed)
        gt_masks = official_masks(truth.lanes, width, height, lane_width) if truth.lanes else None
        for m, root in enumerate(pred_roots):
            predicted = read_lanes(json_path(root, relpath), categories_needed)
            if diagnosis is None:
                counts[m] += frame_counts(truth, gt_masks, predicted, (width, height, lane_width), modes, thresholds)
            else:
                counts[m] += _diagnosed_frame(truth, gt_masks, predicted, (width, height, lane_width), modes,
                                              thresholds, diagnosed, m)
    return counts if diagnosis is None else (counts, diagnosed.result(relpaths))


def _diagnosed_frame(truth: OpenLaneLanes, gt_masks, predicted: OpenLaneLanes, size: tuple[int, int, int],
                     modes: tuple[str, ...], thresholds, diagnosed: DiagnosisCollector, m: int) -> np.ndarray:
    """frame_counts of a frame whose error types `diagnosed` collects in each mode (entry m x
    modes + k): within categories, a false positive that would match a lane of another category
    is a Cat error."""
    similarity = (gt_masks.ious(official_masks(predicted.lanes, *size)) if truth.lanes and predicted.lanes
                  else np.zeros((len(truth.lanes), len(predicted.lanes))))
    counts = np.zeros((len(modes), len(thresholds), 3), np.int64)
    for k, mode in enumerate(modes):
        matrix, other = similarity, None
        if mode == MODES[0]:
            same = np.equal.outer(np.array(truth.categories), np.array(predicted.categories)).reshape(similarity.shape)
            matrix, other = category_iou(similarity, same)
        errors = diagnosed.add(m * len(modes) + k, partial(np.asarray, matrix), other_iou=other)
        assert errors is not None
        tp = np.count_nonzero(errors.matched_iou[None, :] > np.asarray(thresholds)[:, None], axis=1)
        counts[k] = np.stack([tp, errors.n_pred - tp, errors.n_gt - tp], axis=1)
    return counts


def frame_counts(truth: OpenLaneLanes, gt_masks, predicted: OpenLaneLanes, size: tuple[int, int, int],
                 modes: tuple[str, ...], thresholds) -> np.ndarray:
    """(modes, thresholds, 3): TP, FP, FN of one frame (`gt_masks`: the truth's official_masks,
    None without lanes)."""
    counts = np.zeros((len(modes), len(thresholds), 3), np.int64)
    n_gt, n_pred = len(truth.lanes), len(predicted.lanes)
    if n_gt and n_pred:
        assert gt_masks is not None
        similarity = gt_masks.ious(official_masks(predicted.lanes, *size))
    else:
        similarity = np.zeros((n_gt, n_pred))
    for k, mode in enumerate(modes):
        matrix = similarity
        if mode == MODES[0] and n_gt and n_pred:
            same = np.equal.outer(np.array(truth.categories), np.array(predicted.categories))
            matrix = np.where(same, similarity, 0.0)
        matched = matched_result(matrix).matched_iou
        for t, threshold in enumerate(thresholds):
            tp = int(np.count_nonzero(matched > threshold))
            counts[k, t] = (tp, n_pred - tp, n_gt - tp)
    return counts


def score_openlane(labels: str | Path, pred_root: PredictionRoots, list_file: str | Path | None = None,
                   iou: str | None = None, width: int = LANE_WIDTH, modes: tuple[str, ...] = MODES,
                   out: str | Path | None = None, workers: int | None = None, progress: bool = False,
                   announce: Callable[[str], None] | None = None, strict: bool = False, shard: str | None = None,
                   merged: Merged | None = None, diagnose: bool = False,
                   loc_iou: float | None = None) -> OpenLaneScore | None:
    """Score OpenLane JSON predictions mirroring `labels` (`<segment>/<frame>.json`). With `shard`
    ('I/N'), only that share of the segments, written as a part to `out` (None is returned).
    `diagnose`: also the error types (errors.csv, .md, .png; Cat within categories) and every
    frame's counts (frames.csv.gz), as `score culane --diagnose` gives them."""
    thresholds = parse_thresholds(iou or DEFAULT_IOU)
    diagnosis = diagnosis_settings(diagnose, loc_iou, None, thresholds.values)
    check_lane_width(width)
    modes = _checked_modes(modes)
    sharding = Sharding("score openlane", shard, out, merged, dict(
        labels=labels, pred_root=pred_root, list_file=list_file, iou=iou, width=width, modes=modes, strict=strict,
        **given_options(diagnose=diagnose, loc_iou=loc_iou)))
    labels = Path(labels)
    with _taking(out, "score openlane", reads=(labels, list_file)) as folder:
        relpaths = listed_frames(read_list(Path(list_file)) if list_file is not None else every_labelled_frame(labels),
                                 labels, json_path, "annotation")
        trees, warnings = find_prediction_trees(pred_root, relpaths, strict, announce, suffix=".json")
        label_files = [json_path(labels, relpath) for relpath in relpaths]

        def files_of(m: int, relpath: str) -> tuple[Path]:
            return (json_path(trees[m].root, relpath),)

        diagnosed: FrameDiagnoses | None = None
        if merged is not None:
            sharding.check_merged(relpaths, trees, label_files, posixpath.dirname, files_of=files_of)
            counts = sharding.merged_array("sum_counts", (len(trees), len(modes), len(thresholds.values), 3))
            diagnosed = diagnoses_merged(diagnosis, relpaths, sharding.merged_array, len(trees) * len(modes))
        else:
            roots = tuple(tree.root for tree in trees)
            scored = sharding.share(relpaths, posixpath.dirname)  # a segment is a clip
            chunks = [scored[i:i + CHUNK_FRAMES] for i in range(0, len(scored), CHUNK_FRAMES)]
            tasks = [(chunk, labels, roots, IMAGE_WIDTH, IMAGE_HEIGHT, width, modes, thresholds.values, diagnosis)
                     for chunk in chunks]
            pieces = scored_pieces(_score_frames, tasks, workers, progress, announce, trees=trees,
                                   kernel_groups=kernel_groups(("official",), diagnosis))
            pieces, diagnosed = split_diagnosed(pieces, diagnosis)
            counts = sum(pieces, np.zeros((len(trees), len(modes), len(thresholds.values), 3), np.int64))
            if sharding.shard is not None:
                assert folder is not None
                sharding.write_part(folder, relpaths, trees, label_files, scored, {
                    "sum_counts": counts, **diagnosis_part(diagnosis, diagnosed, len(trees) * len(modes))},
                                    files_of=files_of)
                return None
        rows = _official_rows(trees, modes, thresholds.labels, counts)
        score = OpenLaneScore(PlainTable(COLUMNS, rows), thresholds, tuple(t.method for t in trees), modes,
                              len(relpaths), tuple(warnings))
        score = _diagnosed(score, diagnosed, width, diagnosis, partial(_gallery_frame, labels, trees))
        if folder is not None:
            staging = Staging(folder)
            staging.write_text("official.csv", score.rows.to_csv())
            staging.write_text("summary.md", summary_markdown(score, width))
            write_diagnosis(staging, score.diagnosed, score.thresholds.labels[:1])
            folder.commit()
    return score


def _checked_modes(modes) -> tuple[str, ...]:
    modes = tuple(modes)
    if not modes or any(mode not in MODES for mode in modes) or len(set(modes)) != len(modes):
        raise ConfigError(f"matching must be among {', '.join(MODES)}")
    return modes


def _official_rows(trees, modes: tuple[str, ...], labels: tuple[str, ...], counts: np.ndarray) -> tuple:
    """official.csv's rows: a method, matching and threshold each, its counts and F-measure."""
    rows = []
    for m, tree in enumerate(trees):
        for k, mode in enumerate(modes):
            for t, label in enumerate(labels):
                tp, fp, fn = (int(v) for v in counts[m, k, t])
                rows.append((tree.method, mode, label, tp, fp, fn, *f_measure(tp, fp, fn)))
    return tuple(rows)


def _gallery_frame(labels: Path, trees, frame: str) -> GalleryFrame:
    """A frame's lanes read again for the gallery; its image is the frame's path (no image root:
    `show --image-root` gives one)."""
    return GalleryFrame((IMAGE_WIDTH, IMAGE_HEIGHT), read_lanes(json_path(labels, frame), False).lanes,
                        {tree.method: read_lanes(json_path(tree.root, frame), False).lanes for tree in trees}, frame)


def _diagnosed(score: OpenLaneScore, diagnoses: FrameDiagnoses | None, width: int,
               diagnosis: DiagnosisSettings | None,
               frame_lanes: Callable[[str], GalleryFrame] | None = None) -> OpenLaneScore:
    """The score with its diagnosis: every frame in one group (`all`), its segment as its
    sequence; each method's matchings."""
    if diagnosis is None or diagnoses is None:
        return score
    entries = tuple((method, mode) for method in score.methods for mode in score.modes)
    return replace(score, diagnosed=Diagnosed(
        diagnoses, entries, (("all", np.ones(len(diagnoses.frames), bool)),), score.thresholds.labels,
        diagnosis.loc_iou, lambda frame: (posixpath.dirname(frame), ""),
        f"OpenLane 2D, lane2d's IoU F1 ({width} px at {IMAGE_WIDTH}x{IMAGE_HEIGHT})", errors=diagnosis.errors,
        with_categories=MODES[0] in score.modes, frame_lanes=frame_lanes))


def summary_table(score: OpenLaneScore) -> str:
    head = [f"F1@{label} {mode} (%)" for mode in score.modes for label in score.thresholds.labels]
    lines = ["| method | " + " | ".join(head) + " |", "|---" * (len(head) + 1) + "|"]
    rows = {(r[0], r[1], r[2]): r for r in score.rows.rows}
    for method in score.methods:
        cells = []
        for mode in score.modes:
            for label in score.thresholds.labels:
                f1 = rows[(method, mode, label)][8]
                cells.append("n/a" if f1 != f1 else f"{100 * f1:.2f}")
        lines.append(f"| {method} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def summary_markdown(score: OpenLaneScore, width: int) -> str:
    return (f"# OpenLane 2D, official protocol\n\n{score.n_frames:,} images on a {IMAGE_WIDTH}x{IMAGE_HEIGHT} canvas, "
            f"lanes {width} px wide, a match counts when IoU > the threshold (OpenLane eval/LANE_evaluation/lane2d, "
            "8a0ce6b). 'same category': a lane matches only a lane of its own category (the evaluator's default); "
            "'any category': as with its -k flag. Lanes of fewer than two points are left out.\n\n"
            + summary_table(score) + "\n")
