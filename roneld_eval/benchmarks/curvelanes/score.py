"""`score curvelanes`: predicted `.lines.json` files scored as CondLaneNet's lane_metric.py scores
CurveLanes (aliyun/conditional-lane-detection c57b242; official.py), each image at
its own size, every method in one pass; at a fixed score threshold and, when a list is given, the
best F1 over it, labelled as chosen on the test set (as vega's summary reports it).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import partial
from pathlib import Path
from typing import Callable, Sequence

import numpy as np

from ...errors import ConfigError, InputError
from ...datasets._paths import under_root
from .reader import (IMAGE_SUFFIXES, SUFFIX, CurveLanesFrame, every_labelled_image, image_size, lanes_path,
                     read_frame, read_list)

from .official import IOU_THRESHOLD, f_measure, has_zero_step, hits, iou_matrix, matched_lanes
from ...metrics.lane_errors import (DiagnosisCollector, DiagnosisSettings, FrameDiagnoses, diagnosis_part,
                                    diagnosis_settings, diagnoses_merged, kernel_groups, split_diagnosed)
from ...output import Staging
from ...report.diagnosis import Diagnosed, write_diagnosis
from ...report.gallery import GalleryFrame
from ...model import Lane
from ...scoring import PlainTable, PredictionRoots, _taking, find_prediction_trees, listed_frames, scored_pieces
from ...shards import Merged, Sharding, given_options

COLUMNS = ("method", "score_threshold", "chosen", "hits", "predicted", "truth", "precision", "recall", "f1")
CHUNK_FRAMES = 100


@dataclass(frozen=True)
class CurveLanesScore:
    rows: PlainTable
    methods: tuple[str, ...]
    n_frames: int
    warnings: tuple[str, ...] = ()
    diagnosed: Diagnosed | None = None  # --diagnose, --score-sweep: error types, frames, the whole score curve


def _zero_step(path: Path, index: int) -> InputError:
    return InputError(path, f"lane {index} has two equal consecutive points: CondLaneNet's spline divides by zero "
                            "there (and its drawing stops on NaN)")


def _score_frames(args) -> np.ndarray | tuple[np.ndarray, FrameDiagnoses | None]:
    """(methods, thresholds, 3): hits, predicted and ground-truth lanes of a chunk of images; with
    `diagnosis`, and the images' error types at the first threshold (the fixed one) and their counts
    at each score threshold of its sweep."""
    relpaths, labels, images, pred_roots, thresholds, diagnosis = args
    counts = np.zeros((len(pred_roots), len(thresholds), 3), np.int64)
    diagnosed = DiagnosisCollector(diagnosis, len(pred_roots))
    for relpath in relpaths:
        width, height = image_size(images, relpath)
        path = lanes_path(labels, relpath)
        truth = checked_truth(read_frame(path, True), path, width, height)
        for m, root in enumerate(pred_roots):
            path = lanes_path(root, relpath)
            counts[m] += _method_frame(truth, read_frame(path, True), path, (width, height), thresholds, diagnosed, m)
    return counts if diagnosis is None else (counts, diagnosed.result(relpaths))


def _method_frame(truth: tuple, frame: CurveLanesFrame, path, size: tuple[int, int], thresholds: Sequence[float],
                  diagnosed: DiagnosisCollector, m: int) -> np.ndarray:
    """frame_counts of a method's image; when diagnosing, from the one IoU matrix (each lane drawn
    once) also its error types among the lanes kept at the fixed (first) threshold, under the
    metric's own assignment, and with a sweep its counts at each of the sweep's thresholds."""
    settings = diagnosed.settings
    if settings is None:
        return frame_counts(truth, frame, path, *size, thresholds)
    swept = [] if settings.sweep is None else settings.sweep.limits.tolist()
    kept, matrix, column = kept_matrix(truth, frame, path, *size, [*thresholds, *swept])
    counts = kept_counts(len(truth), kept, matrix, column)
    fixed = (matrix[:, [column[k] for k in kept[0]]] if matrix is not None
             else np.zeros((len(truth), len(kept[0]))))
    diagnosed.add(m, partial(np.asarray, fixed), match=matched_lanes(fixed))
    diagnosed.add_swept(m, counts[len(thresholds):, :1], counts[len(thresholds):, 1])
    return counts[:len(thresholds)]


def checked_truth(frame: CurveLanesFrame, path, width: int, height: int) -> tuple:
    """The ground-truth lanes of an image, refused where CondLaneNet's spline would divide by zero."""
    for index, lane in enumerate(frame.lanes):
        if has_zero_step(lane, width, height):
            raise _zero_step(path, index)
    return frame.lanes


def frame_counts(truth: tuple, frame: CurveLanesFrame, path, width: int, height: int, thresholds) -> np.ndarray:
    """(thresholds, 3): hits, predicted and ground-truth lanes of one image.

    Each lane is drawn once; a score threshold keeps a subset of the predictions, whose columns
    of the one IoU matrix are matched (the same IoUs, in the same order, as drawing the kept
    lanes alone)."""
    return kept_counts(len(truth), *kept_matrix(truth, frame, path, width, height, thresholds))


def kept_matrix(truth: tuple, frame: CurveLanesFrame, path, width: int, height: int,
                thresholds) -> tuple[list[list[int]], np.ndarray | None, dict[int, int]]:
    """(the predictions each score threshold keeps, the IoU matrix of the ground truth against
    every prediction any keeps (None without ground truth), each such prediction's column)."""
    kept = [[k for k, score in enumerate(frame.scores) if score is None or score > threshold]
            for threshold in thresholds]
    used = sorted({k for chosen in kept for k in chosen})
    _check_kept(frame, kept, path, width, height)
    matrix = iou_matrix(truth, [frame.lanes[k] for k in used], width, height) if truth else None
    return kept, matrix, {k: j for j, k in enumerate(used)}


def kept_counts(n_truth: int, kept: list[list[int]], matrix: np.ndarray | None, column: dict[int, int]) -> np.ndarray:
    """(thresholds, 3): hits, predicted and ground-truth lanes at each threshold of kept_matrix."""
    counts = np.zeros((len(kept), 3), np.int64)
    for t, chosen in enumerate(kept):
        found = 0 if matrix is None or not chosen else hits(matrix[:, [column[k] for k in chosen]])
        counts[t] = (found, len(chosen), n_truth)
    return counts


def _check_kept(frame: CurveLanesFrame, kept: list[list[int]], path, width: int, height: int) -> None:
    """Refuse a kept lane CondLaneNet's spline divides by zero on, in threshold order, named by
    its place among the lanes kept."""
    for chosen in kept:
        for index, k in enumerate(chosen):
            if has_zero_step(frame.lanes[k], width, height):
                raise _zero_step(path, index)


# The score thresholds vega's shipped lane configuration searches (huawei-noah/vega 0f1d0d0,
# examples/nas/auto_lane/auto_lane.yml, LaneMetric thresh_list; LaneMetric.summary takes the best):
# `score curvelanes` reports the best of them unless told another list.
VEGA_THRESHOLDS = (0.56, 0.60, 0.63, 0.66, 0.70, 0.73, 0.76, 0.80, 0.83, 0.86, 0.90, 0.93)


def _each_image(relpath: str) -> str:
    return relpath  # every image is its own clip


def score_curvelanes(labels: str | Path, pred_root: PredictionRoots, image_root: str | Path,
                     list_file: str | Path | None = None, score_threshold: float = 0.0,
                     best_of: Sequence[float] = (), out: str | Path | None = None, workers: int | None = None,
                     progress: bool = False, announce: Callable[[str], None] | None = None,
                     strict: bool = False, shard: str | None = None,
                     merged: Merged | None = None, diagnose: bool = False, loc_iou: float | None = None,
                     score_sweep: str | None = None) -> CurveLanesScore | None:
    """Score CurveLanes predictions mirroring `labels`; a lane with a score is kept above the threshold.
    With `shard` ('I/N'), only that share of the images, written as a part to `out` (None is returned).
    `diagnose`: the error types at `score_threshold` (errors.csv, .md, .png) and every image's counts
    (frames.csv.gz); `score_sweep` ('0.00:0.95:0.05'): the whole curve behind `best_of` (a lane kept
    when its score is above each threshold), as `score culane` gives them."""
    thresholds = score_thresholds(score_threshold, best_of)
    diagnosis = diagnosis_settings(diagnose, loc_iou, score_sweep, (IOU_THRESHOLD,), strict=True)
    sharding = Sharding("score curvelanes", shard, out, merged, dict(
        labels=labels, pred_root=pred_root, image_root=image_root, list_file=list_file,
        score_threshold=float(score_threshold), best_of=[float(t) for t in best_of], strict=strict,
        **given_options(diagnose=diagnose, loc_iou=loc_iou, score_sweep=score_sweep)))
    labels, images = Path(labels), Path(image_root)
    with _taking(out, "score curvelanes", reads=(labels, images, list_file)) as folder:
        relpaths = listed_frames(read_list(Path(list_file)) if list_file is not None else every_labelled_image(labels),
                                 labels, lanes_path, "labels")
        trees, warnings = find_prediction_trees(pred_root, relpaths, strict, announce, suffix=SUFFIX)
        label_files = _label_files(labels, images, relpaths)

        def files_of(m: int, relpath: str) -> tuple[Path]:
            return (lanes_path(trees[m].root, relpath),)

        diagnoses: FrameDiagnoses | None = None
        if merged is not None:
            sharding.check_merged(relpaths, trees, label_files, _each_image, files_of=files_of)
            counts = sharding.merged_array("sum_counts", (len(trees), len(thresholds), 3))
            diagnoses = diagnoses_merged(diagnosis, relpaths, sharding.merged_array, len(trees))
        else:
            roots = tuple(tree.root for tree in trees)
            scored = sharding.share(relpaths, _each_image)
            chunks = [scored[i:i + CHUNK_FRAMES] for i in range(0, len(scored), CHUNK_FRAMES)]
            tasks = [(chunk, labels, images, roots, thresholds, diagnosis) for chunk in chunks]
            pieces, diagnoses = split_diagnosed(scored_pieces(_score_frames, tasks, workers, progress, announce,
                                                     kernel_groups=kernel_groups((), diagnosis), unit="image",
                                                     trees=trees), diagnosis)
            counts = sum(pieces, np.zeros((len(trees), len(thresholds), 3), np.int64))
            if sharding.shard is not None:
                assert folder is not None
                sharding.write_part(folder, relpaths, trees, label_files, scored, {
                    "sum_counts": counts, **diagnosis_part(diagnosis, diagnoses, len(trees))},
                                    files_of=files_of)
                return None
        rows = [row for m, tree in enumerate(trees) for row in method_rows(tree.method, thresholds, best_of, counts[m])]
        score = CurveLanesScore(PlainTable(COLUMNS, tuple(rows)), tuple(t.method for t in trees), len(relpaths),
                                tuple(warnings))
        score = _diagnosed(score, diagnoses, thresholds[0], diagnosis, partial(_gallery_frame, labels, images, trees))
        if folder is not None:
            staging = Staging(folder)
            staging.write_text("official.csv", score.rows.to_csv())
            write_diagnosis(staging, score.diagnosed, (IOU_LABEL,))
            folder.commit()
    return score


def _label_files(labels: Path, images: Path, relpaths: list[str]) -> list[Path]:
    """The labels, and the images whose headers give each image's size: what a part fingerprints."""
    return [path for relpath in relpaths for path in (
        lanes_path(labels, relpath), *(under_root(images, relpath + suffix) for suffix in IMAGE_SUFFIXES))]


IOU_LABEL = f"{IOU_THRESHOLD:.2f}"  # as the other benchmarks' thresholds are written


def _measure(tp: int, fp: int, fn: int) -> tuple[float, float, float]:
    """The metric's precision, recall and F1 (with its epsilon guards) of TP, FP and FN."""
    return f_measure(tp, tp + fp, tp + fn)


def _gallery_frame(labels: Path, images: Path, trees, score_threshold: float, frame: str) -> GalleryFrame:
    """An image's lanes read again for the gallery (predictions as kept at the fixed threshold)."""
    def kept(found: CurveLanesFrame) -> list[Lane]:
        return [Lane(np.array(lane, np.float64).reshape(-1, 2)) for lane, score in zip(found.lanes, found.scores)
                if score is None or score > score_threshold]

    image = next((frame + suffix for suffix in IMAGE_SUFFIXES if under_root(images, frame + suffix).is_file()), None)
    return GalleryFrame(image_size(images, frame), kept(read_frame(lanes_path(labels, frame), True)),
                        {tree.method: kept(read_frame(lanes_path(tree.root, frame), True)) for tree in trees}, image)


def _diagnosed(score: CurveLanesScore, diagnoses: FrameDiagnoses | None, score_threshold: float,
               diagnosis: DiagnosisSettings | None,
               frame_lanes: Callable[..., GalleryFrame] | None = None) -> CurveLanesScore:
    """The score with its diagnosis: every image in one group (`all`), none in a sequence."""
    if diagnosis is None or diagnoses is None:
        return score
    return replace(score, diagnosed=Diagnosed(
        diagnoses, tuple((method, "") for method in score.methods), (("all", np.ones(len(diagnoses.frames), bool)),),
        (IOU_LABEL,), diagnosis.loc_iou, lambda frame: ("", ""),
        f"CurveLanes, CondLaneNet's lane IoU F1 (lanes kept when score > {score_threshold:g})", diagnosis.sweep,
        diagnosis.errors, measure=_measure,
        frame_lanes=None if frame_lanes is None else partial(frame_lanes, score_threshold)))


def score_thresholds(score_threshold: float, best_of: Sequence[float]) -> list[float]:
    """The fixed threshold, then those of `best_of` that differ from it."""
    thresholds = [float(score_threshold), *(float(t) for t in best_of if float(t) != float(score_threshold))]
    if not all(np.isfinite(thresholds)):
        raise ConfigError("score thresholds must be finite numbers")
    return thresholds


def method_rows(method: str, thresholds: Sequence[float], best_of: Sequence[float], counts) -> list[tuple]:
    """official.csv's rows of one method from its (thresholds, 3) counts: the fixed threshold's,
    and the best of `best_of` (labelled as chosen on the test set)."""
    rows = [_row(method, thresholds[0], "fixed", counts[0])]
    if best_of:
        listed = [t for t, value in enumerate(thresholds) if value in [float(b) for b in best_of]]
        best = max(listed, key=lambda t: (f_measure(*counts[t])[2], -t))
        rows.append(_row(method, thresholds[best], "best on the test set", counts[best]))
    return rows


def _row(method: str, threshold: float, chosen: str, counts) -> tuple:
    hits, predicted, truth = (int(v) for v in counts)
    return (method, threshold, chosen, hits, predicted, truth, *f_measure(hits, predicted, truth))
