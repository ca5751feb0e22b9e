"""`score vil100`: predicted `.lines.txt` files scored as MMA-Net's evaluation/evaluate_iou.py and
its modified CULane evaluator score them (yujun0-0/MMA-Net 8f95908), every method in one pass
over the ground truth, every threshold at once (the C++ tool needs one run per sequence and
threshold). Sequences are scored at their own size, in parallel.
"""

from __future__ import annotations

import math
from functools import partial
from operator import attrgetter

import numpy as np
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Callable, Collection, Iterable, Sequence

from ...config import check_lane_width

from ...thresholds import Thresholds, parse_thresholds
from .reader import SCENARIOS, Vil100Set, labels_path, read_vil100, scenarios_of
from ...datasets._paths import under_root
from ...errors import ConfigError, InputError
from ...metrics.line_masks import LaneMask
from ...model import Lane, image_stem
from ...lanes_io import check_coordinates, check_inside_image, read_lines_txt, read_scores_beside
from ...metrics.lane_errors import (DiagnosisCollector, DiagnosisSettings, FrameDiagnoses, diagnosis_part,
                                    diagnosis_settings, diagnoses_merged, joined_diagnoses, kernel_groups)
from ...metrics.lane_iou_f1 import FrameMatches, frame_similarity, match_frame, f_measure, official_masks
from ...report.diagnosis import Diagnosed, write_diagnosis
from ...report.gallery import GalleryFrame
from .acc import AccFrame, mmanet_frame, rvld_frame
from .acc import means as acc_means
from .official import PooledScore, SequenceScore, frame_miou, pooled, printed, sequence_score
from .temporal import TemporalCounts, assigned_ious, lane_mask, links, sequence_counts, usable
from ...output import Staging
from ...scoring import PlainTable, PredictionRoots, _taking, find_prediction_trees, only_frames, percent, scored_pieces
from ...shards import Merged, Sharding, given_options

DEFAULT_IOU = "0.5,0.8"  # evaluate_iou.py:23 ("Set iou to 0.5 or 0.8"); papers report both
LANE_WIDTH = 30  # evaluate_iou.py:22, for every sequence whatever its size
COLUMNS = ("method", "category", "threshold", "tp", "fp", "fn", "precision", "recall", "f1", "miou", "sequences")
TEMPORAL_COLUMNS = ("method", "category", "tau", "pairs", "stable", "jump", "missing", "rs", "rj", "rm")
ACC_COLUMNS = ("method", "category", "version", "frames", "accuracy", "fp", "fn", "stopping_lanes")
# the two Acc/FP/FN scripts (metrics.vil100_acc), as acc.csv and summary.csv name them
ACC_VERSIONS = ("mmanet", "rvld")


@dataclass(frozen=True)
class Vil100Score:
    """Official VIL-100 scores of one or more methods: `rows` as official.csv holds them (per
    sequence, per scenario, then 'all', at each threshold)."""

    rows: PlainTable
    temporal_rows: PlainTable | None  # RVLD's Rs, Rj, Rm per sequence and over all, at each threshold as tau
    thresholds: Thresholds
    methods: tuple[str, ...]
    n_frames: int
    n_sequences: int
    overall: dict  # (method, threshold label) -> PooledScore
    temporal_overall: dict  # (method, threshold label) -> TemporalCounts (empty without the temporal metrics)
    acc_rows: PlainTable | None = None  # Acc/FP/FN per sequence, scenario and all, in both versions
    acc_overall: dict = field(default_factory=dict)  # (method, version) -> AccMeans; MMA-Net's needs masks
    warnings: tuple[str, ...] = ()
    diagnosed: Diagnosed | None = None  # --diagnose, --score-sweep: error types, frames, score sweep


@dataclass
class ScoredSequence:
    """One sequence against every method: per method, each frame's matched result and mIoU;
    with the temporal metrics, the ground truth's links between consecutive frames and, per
    method, each frame's assigned IoUs (RVLD's own IoU)."""

    frames: list[list[tuple[FrameMatches, float]]]
    links: list[list[tuple[int, int]]] = field(default_factory=list)
    assigned: list[list[np.ndarray]] = field(default_factory=list)
    # per method, each frame's Acc/FP/FN: RVLD's version, and MMA-Net's (None without instance masks)
    acc: list[list[tuple[AccFrame, AccFrame | None]]] = field(default_factory=list)
    # frames whose ground truth reaches beyond the sequence's size (a wrong size?); per method,
    # masks of another size than the sequence's (the script reads them at their own)
    truth_outside: list[str] = field(default_factory=list)
    odd_masks: list[list[str]] = field(default_factory=list)
    diagnoses: FrameDiagnoses | None = None  # --diagnose, --score-sweep


@dataclass(frozen=True)
class SequenceTotals:
    """A sequence reduced to what the tables need, as arrays a shard's part can hold: per method
    and threshold TP, FP, FN and RVLD's stable, jump and missing pairs; per method its mIoU; per
    frame and method each Acc version's accuracy, FP, FN and stopping lanes (means over frames in
    frame order need the frames); per frame the flags behind the size warnings."""

    counts: np.ndarray  # (methods, thresholds, 3) int64: tp, fp, fn
    temporal: np.ndarray  # (methods, thresholds, 3) int64: stable, jump, missing (zeros without)
    miou: np.ndarray  # (methods,) float64, the sequence's mIoU before printing
    acc: np.ndarray  # (frames, methods, versions, 4) float64
    truth_outside: np.ndarray  # (frames,) int64: 1 where the ground truth reaches past the size
    odd_masks: np.ndarray  # (frames, methods) int64: 1 where a mask is of another size

    def sequence_score(self, name: str, m: int, t: int) -> SequenceScore:
        tp, fp, fn = (int(v) for v in self.counts[m, t])
        return SequenceScore(name, tp, fp, fn, float(self.miou[m]))

    def temporal_counts(self, m: int, t: int) -> TemporalCounts:
        return TemporalCounts(*(int(v) for v in self.temporal[m, t]))

    def acc_frames(self, m: int, v: int) -> list[AccFrame]:
        return [AccFrame(float(a), float(p), float(n), int(k)) for a, p, n, k in self.acc[:, m, v].tolist()]


def versions_of(pred_format: str) -> tuple[str, ...]:
    """The Acc versions a prediction format gives: MMA-Net's reads instance masks only."""
    return ACC_VERSIONS if pred_format == "png" else ACC_VERSIONS[1:]


def sequence_totals(piece: ScoredSequence, relpaths: Sequence[str], thresholds: Thresholds, temporal: bool,
                    versions: Sequence[str]) -> SequenceTotals:
    n_methods, n_frames = len(piece.frames), len(relpaths)
    counts = np.zeros((n_methods, len(thresholds.values), 3), np.int64)
    temporal_counts = np.zeros_like(counts)
    miou = np.zeros(n_methods)
    acc = np.zeros((n_frames, n_methods, len(versions), 4))
    for m, frames in enumerate(piece.frames):
        for t, value in enumerate(thresholds.values):
            score = sequence_score("", [r for r, _ in frames], [v for _, v in frames], value)
            counts[m, t] = score.tp, score.fp, score.fn
            miou[m] = score.miou
            if temporal:
                found = sequence_counts(piece.links, piece.assigned[m], value)
                temporal_counts[m, t] = found.stable, found.jump, found.missing
        for v, version in enumerate(versions):
            for k, pair in enumerate(piece.acc[m]):
                frame = pair[ACC_VERSIONS[::-1].index(version)]  # (RVLD's, MMA-Net's)
                assert frame is not None
                acc[k, m, v] = frame.accuracy, frame.fp, frame.fn, frame.stopping
    outside = set(piece.truth_outside)
    odd = [set(names) for names in piece.odd_masks] or [set()] * n_methods
    return SequenceTotals(counts, temporal_counts, miou, acc, np.array([r in outside for r in relpaths], np.int64),
                          np.array([[r in names for names in odd] for r in relpaths], np.int64).reshape(n_frames, -1))


PRED_FORMATS = ("lines", "png")  # .lines.txt, or MMA-Net's instance masks (maps.vil100_png)
_SUFFIXES = {"lines": ".lines.txt", "png": ".png"}


def _prediction_path(root: Path, relpath: str, pred_format: str) -> Path:
    return under_root(root, f"{image_stem(relpath)}{_SUFFIXES[pred_format]}")


def _read_predictions(root: Path, relpath: str, pred_format: str):
    """(lanes, the instance mask's fits and height, or None for lane files)."""
    path = _prediction_path(root, relpath, pred_format)
    if pred_format == "png":
        from .maps_png import read_instance_png

        mask = read_instance_png(path)
        return mask.lanes, mask
    predictions = read_lines_txt(path)
    check_coordinates(predictions, path)
    return predictions, None


@dataclass(frozen=True)
class FrameTruth:
    """A frame's ground truth as every metric of `score vil100` draws it."""

    lanes: tuple[Lane, ...]
    masks: Any  # the CULane evaluator's masks (None without lanes)
    linked: tuple[LaneMask, ...]  # RVLD's masks of its usable lanes, linked across frames (empty without temporal)
    outside: bool  # reaching past the sequence's size (a wrong size? the warnings say)


def frame_truth(labels: Path, relpath: str, width: int, height: int, lane_width: int, temporal: bool) -> FrameTruth:
    path = labels_path(labels, relpath)
    truth = read_lines_txt(path)  # a missing file: no lanes, as the C++ reader ("fail")
    check_inside_image(truth, path, width, height)
    outside = any(((lane.xs > width + 1) | (lane.ys > height + 1)).any() for lane in truth)
    masks = official_masks(truth, width, height, lane_width) if truth else None
    linked = tuple(lane_mask(lane, width, height) for lane in usable(truth)) if temporal else ()
    return FrameTruth(tuple(truth), masks, linked, outside)


@dataclass(frozen=True)
class FrameOutcome:
    """One frame of one method: matched IoUs and mIoU, RVLD's Acc/FP/FN, and each linked
    ground-truth lane's assigned IoU (empty without the temporal metrics)."""

    matches: FrameMatches
    miou: float
    acc: AccFrame
    assigned: np.ndarray


def frame_outcome(truth: FrameTruth, predictions: Sequence[Lane], width: int, height: int, lane_width: int,
                  temporal: bool, matches: FrameMatches | None = None) -> FrameOutcome:
    """`matches`: the frame's official matching where the caller has it already (a diagnosis)."""
    if matches is None:
        matches = match_frame(list(truth.lanes), list(predictions), width, height, lane_width, gt_masks=truth.masks)
    assigned = (assigned_ious(truth.linked, [lane_mask(lane, width, height) for lane in usable(predictions)])
                if temporal else np.zeros(0))
    return FrameOutcome(matches, frame_miou(matches), rvld_frame(predictions, truth.lanes), assigned)


def _score_sequence(args) -> ScoredSequence:
    relpaths, labels, pred_roots, width, height, lane_width, temporal, pred_format, diagnosis = args
    out = ScoredSequence([[] for _ in pred_roots], [], [[] for _ in pred_roots], [[] for _ in pred_roots], [],
                         [[] for _ in pred_roots])
    diagnosed = DiagnosisCollector(diagnosis, len(pred_roots))
    previous: list | None = None
    for relpath in relpaths:
        label = frame_truth(labels, relpath, width, height, lane_width, temporal)
        truth = list(label.lanes)
        if label.outside:
            out.truth_outside.append(relpath)
        if temporal:
            linked = list(label.linked)
            out.links.append([] if previous is None else links(linked, previous))
            previous = linked
        for m, root in enumerate(pred_roots):
            _score_method_frame(out, m, root, relpath, label, truth, (width, height, lane_width), temporal,
                                pred_format, diagnosed)
    out.diagnoses = diagnosed.result(relpaths)
    return out


def _score_method_frame(out: ScoredSequence, m: int, root: Path, relpath: str, label: FrameTruth, truth: list,
                        size: tuple[int, int, int], temporal: bool, pred_format: str,
                        diagnosed: DiagnosisCollector) -> None:
    """Method m's frame added to `out`: its matches and mIoU, both Accs, its assignment (temporal),
    and whether its instance mask is of another size than the sequence's."""
    width, height, lane_width = size
    predictions, mask = _read_predictions(root, relpath, pred_format)
    if mask is not None and mask.height is not None and (mask.width, mask.height) != (width, height):
        out.odd_masks[m].append(relpath)
    outcome = frame_outcome(label, predictions, width, height, lane_width, temporal,
                            _diagnose(diagnosed, m, label, predictions, root, relpath, size))
    out.frames[m].append((outcome.matches, outcome.miou))
    mmanet = None if mask is None else mmanet_frame(mask.fits, truth, mask.height or height)
    out.acc[m].append((outcome.acc, mmanet))
    if temporal:
        out.assigned[m].append(outcome.assigned)


def _diagnose(diagnosed: DiagnosisCollector, m: int, truth: FrameTruth, predictions: Sequence[Lane], root: Path,
              relpath: str, size: tuple[int, int, int]) -> FrameMatches | None:
    """When diagnosing, a method's frame's error types and score sweep (its scores beside its lanes),
    and its official matching from the same IoUs (so its lanes are drawn once); else None."""
    if diagnosed.settings is None:
        return None
    errors = diagnosed.add(m, partial(frame_similarity, len(truth.lanes), truth.masks, list(predictions), *size),
                           partial(read_scores_beside, _prediction_path(root, relpath, "lines"), len(predictions)))
    assert errors is not None
    return FrameMatches(errors.n_gt, errors.n_pred, errors.matched_iou)


def score_vil100(labels: str | Path, pred_root: PredictionRoots, list_file: str | Path | None = None,
                 image_root: str | Path | None = None, json_root: str | Path | None = None,
                 sizes_file: str | Path | None = None, iou: str | None = None, width: int = LANE_WIDTH,
                 out: str | Path | None = None, workers: int | None = None, progress: bool = False,
                 announce: Callable[[str], None] | None = None, strict: bool = False,
                 temporal: bool = True, pred_format: str = "lines", shard: str | None = None,
                 merged: Merged | None = None, diagnose: bool = False, loc_iou: float | None = None,
                 score_sweep: str | None = None, frames: Collection[str] | None = None) -> Vil100Score | None:
    """Score `.lines.txt` predictions mirroring `labels` (`<sequence>/<frame>.lines.txt`).

    Sizes come from exactly one of `image_root`, `json_root` and `sizes_file`. `iou`: one
    threshold, a comma list or a grid (default 0.5 and 0.8). `temporal`: also RVLD's Rs, Rj and
    Rm with each threshold as tau. `pred_format`: "lines" (`.lines.txt`) or "png" (MMA-Net's
    instance masks `<sequence>/<frame>.png`, converted as its generate_iou_pred_txt.py converts
    them). `out` gets official.csv, temporal.csv, summary.csv and summary.md. With `shard`
    ('I/N'), only that share of the sequences, written as a part to `out` (None is returned).
    `diagnose` and `score_sweep`: as `score culane` takes them (scores from `.scores.txt` files).
    """
    thresholds = parse_thresholds(iou or DEFAULT_IOU)
    diagnosis = _diagnosis(diagnose, loc_iou, score_sweep, thresholds, shard, pred_format)
    check_lane_width(width)
    sharding = Sharding("score vil100", shard, out, merged, dict(
        labels=labels, pred_root=pred_root, list_file=list_file, image_root=image_root, json_root=json_root,
        sizes_file=sizes_file, iou=iou, width=width, strict=strict, temporal=temporal, pred_format=pred_format,
        **given_options(diagnose=diagnose, loc_iou=loc_iou, score_sweep=score_sweep)),
        paths=("labels", "list_file", "image_root", "json_root", "sizes_file"))
    versions = versions_of(pred_format)
    with _taking(out, "score vil100", reads=(labels, list_file, image_root, json_root, sizes_file)) as folder:
        dataset = _only(read_vil100(labels, list_file, image_root, json_root, sizes_file), frames, shard)
        relpaths = [relpath for listed in dataset.sequences.values() for relpath in listed]
        trees, warnings = find_prediction_trees(pred_root, relpaths, strict, announce, suffix=_SUFFIXES[pred_format])
        warnings = _unlabelled_warning(dataset, len(relpaths), strict) + warnings
        label_files = [labels_path(dataset.labels, relpath) for relpath in relpaths]
        sizes = {name: list(size) for name, size in dataset.sizes.items()}  # the shards must have read them too

        def files_of(m: int, relpath: str) -> tuple[Path]:
            return (_prediction_path(trees[m].root, relpath, pred_format),)

        diagnoses: FrameDiagnoses | None = None
        if merged is not None:
            sharding.check_merged(relpaths, trees, label_files, _sequence_of, sizes, files_of=files_of)
            totals = _merged_totals(sharding, dataset, len(trees), len(thresholds.values), len(versions))
            diagnoses = diagnoses_merged(diagnosis, relpaths, sharding.merged_array, len(trees))
        else:
            share = set(sharding.share(relpaths, _sequence_of))
            names = [name for name, frames in dataset.sequences.items() if frames[0] in share]
            scored = _scored_sequences(dataset, names, trees, width, temporal, pred_format, diagnosis, workers,
                                       progress, announce)
            totals = [sequence_totals(piece, dataset.sequences[name], thresholds, temporal, versions)
                      for name, piece in zip(names, scored)]
            diagnoses = joined_diagnoses(map(attrgetter("diagnoses"), scored))
            if sharding.shard is not None:
                assert folder is not None
                sharding.write_part(folder, relpaths, trees, label_files,
                                    [r for name in names for r in dataset.sequences[name]],
                                    {**_part_arrays(totals, len(trees), len(thresholds.values), len(versions)),
                                     **diagnosis_part(diagnosis, diagnoses, len(trees))}, sizes, files_of=files_of)
                return None
        warnings += _size_warnings(dataset, totals, trees)
        score = _vil100_score(dataset, trees, totals, thresholds, temporal, versions, len(relpaths), warnings)
        score = _diagnosed(score, diagnoses, width, diagnosis, _gallery_lanes(dataset, trees), image_root)
        if folder is not None:
            _write_score(folder, score, width)
    return score


def _scored_sequences(dataset: Vil100Set, names: list[str], trees, width: int, temporal: bool, pred_format: str,
                      diagnosis, workers: int | None, progress: bool, announce) -> list:
    """Every method's results on each named sequence, a sequence a task, in their order."""
    roots = tuple(tree.root for tree in trees)
    tasks = [(dataset.sequences[name], dataset.labels, roots, *dataset.sizes[name], width, temporal,
              pred_format, diagnosis) for name in names]
    # instance masks are mostly decoded by the PNG maps' kernel (maps.vil100_png)
    groups = kernel_groups(("official", "maps") if pred_format == "png" else ("official",), diagnosis)
    return scored_pieces(_score_sequence, tasks, workers, progress, announce, kernel_groups=groups, trees=trees)


def _unlabelled_warning(dataset: Vil100Set, listed: int, strict: bool) -> list[str]:
    """The warning of listed frames without a ground-truth file (an error with `strict`): every
    VIL-100 test frame has one (40 are empty), so a missing one is a wrong list or folder."""
    if not dataset.unlabelled:
        return []
    first = labels_path(dataset.labels, dataset.unlabelled[0])
    said = f"{len(dataset.unlabelled):,} of {listed:,} listed frames have no ground-truth file (first: {first})"
    if strict:
        raise InputError(dataset.labels, f"{said}; --strict needs every one")
    return [f"warning: {said}; they count as frames without lanes, as MMA-Net's evaluator reads them"]


def _vil100_score(dataset: Vil100Set, trees, totals, thresholds: Thresholds, temporal: bool, versions,
                  n_frames: int, warnings: list[str]) -> Vil100Score:
    """The score's tables from every sequence's totals: official, temporal (with `temporal`) and Acc."""
    methods = tuple(tree.method for tree in trees)
    names = list(dataset.sequences)
    rows, overall = official_rows(names, methods, totals, thresholds)
    temporal_table, temporal_overall = (temporal_rows(names, methods, totals, thresholds) if temporal
                                        else ([], {}))
    acc_table, acc_overall = acc_rows(names, methods, totals, versions)
    return Vil100Score(PlainTable(COLUMNS, tuple(rows)),
                       PlainTable(TEMPORAL_COLUMNS, tuple(temporal_table)) if temporal else None,
                       thresholds, methods, n_frames, len(dataset.sequences), overall, temporal_overall,
                       PlainTable(ACC_COLUMNS, tuple(acc_table)), acc_overall, tuple(warnings))


def _write_score(folder, score: Vil100Score, width: int) -> None:
    """official.csv, temporal.csv (where scored), acc.csv, summary.csv and .md, and the diagnosis."""
    staging = Staging(folder)
    staging.write_text("official.csv", score.rows.to_csv())
    if score.temporal_rows is not None:
        staging.write_text("temporal.csv", score.temporal_rows.to_csv())
    assert score.acc_rows is not None
    staging.write_text("acc.csv", score.acc_rows.to_csv())
    staging.write_text("summary.csv", summary_rows(score).to_csv())
    staging.write_text("summary.md", summary_markdown(score, width))
    write_diagnosis(staging, score.diagnosed, score.thresholds.labels)
    folder.commit()


def _diagnosis(diagnose: bool, loc_iou: float | None, score_sweep: str | None, thresholds: Thresholds,
               shard: str | None, pred_format: str) -> DiagnosisSettings | None:
    """The prediction format checked, and --diagnose's settings (which read lane files)."""
    if pred_format not in PRED_FORMATS:
        raise ConfigError(f"prediction format must be one of {', '.join(PRED_FORMATS)}, got {pred_format!r}")
    diagnosis = diagnosis_settings(diagnose, loc_iou, score_sweep, thresholds.values)
    if diagnosis is not None and pred_format != "lines":
        raise ConfigError("--diagnose and --score-sweep read lane files: give them with --pred-format lines")
    return diagnosis


def _scenario_name(code: int) -> str:
    """A scenario's category as official.csv names it: 'scenario 2 (curved road)'."""
    return f"scenario {code} ({SCENARIOS[code]})"


def _gallery_lanes(dataset, trees) -> Callable[[str], GalleryFrame]:
    """A frame's lanes read again for the gallery, at its sequence's size; its image `<frame>.jpg`."""
    def lanes_of(frame: str) -> GalleryFrame:
        width, height = dataset.sizes[_sequence_of(frame)]
        predicted = {tree.method: read_lines_txt(_prediction_path(tree.root, frame, "lines")) for tree in trees}
        return GalleryFrame((width, height), read_lines_txt(labels_path(dataset.labels, frame)), predicted,
                            f"{frame}.jpg")
    return lanes_of


def _diagnosed(score: Vil100Score, diagnoses: FrameDiagnoses | None, width: int,
               diagnosis: DiagnosisSettings | None, frame_lanes: Callable[[str], GalleryFrame] | None = None,
               image_root: str | Path | None = None) -> Vil100Score:
    """The score with its diagnosis: frames grouped by scenario (each sequence's, from its name;
    those with frames) then all, as official.csv groups them; a frame's category names every
    scenario of its sequence."""
    if diagnosis is None or diagnoses is None:
        return score
    codes = [scenarios_of(_sequence_of(frame)) for frame in diagnoses.frames]
    groups = [(_scenario_name(code), np.array([code in found for found in codes], bool))
              for code in range(len(SCENARIOS))]
    groups = [(name, inside) for name, inside in groups if inside.any()] + [("all", np.ones(len(codes), bool))]

    def facts(frame: str) -> tuple[str, str]:
        sequence = _sequence_of(frame)
        return sequence, "|".join(_scenario_name(code) for code in scenarios_of(sequence) if code < len(SCENARIOS))

    return replace(score, diagnosed=Diagnosed(
        diagnoses, tuple((method, "") for method in score.methods), tuple(groups), score.thresholds.labels,
        diagnosis.loc_iou, facts, f"VIL-100, MMA-Net's lane IoU F1 ({width} px at each sequence's size)",
        diagnosis.sweep, diagnosis.errors, frame_lanes=frame_lanes,
        image_root=None if image_root is None else str(image_root)))


def _sequence_of(relpath: str) -> str:
    return relpath.split("/")[0]


# A part's arrays: per sequence (counts, temporal, miou) and per frame (acc, flags), in list order.
_PER_SEQUENCE = ("counts", "temporal", "miou")
_PER_FRAME = ("acc", "truth_outside", "odd_masks")


def _part_arrays(totals: Sequence[SequenceTotals], n_methods: int, n_thresholds: int,
                 n_versions: int) -> dict[str, np.ndarray]:
    shapes = {"counts": (n_methods, n_thresholds, 3), "temporal": (n_methods, n_thresholds, 3),
              "miou": (n_methods,), "acc": (n_methods, n_versions, 4), "truth_outside": (), "odd_masks": (n_methods,)}
    out = {}
    for name in (*_PER_SEQUENCE, *_PER_FRAME):
        arrays = [getattr(piece, name) for piece in totals]
        dtype = np.float64 if name in ("miou", "acc") else np.int64
        if name in _PER_SEQUENCE:
            out[f"cat_{name}"] = np.array(arrays, dtype).reshape(-1, *shapes[name])
        else:
            out[f"cat_{name}"] = (np.concatenate(arrays).astype(dtype) if arrays
                                  else np.zeros((0, *shapes[name]), dtype))
    return out


def _merged_totals(sharding: Sharding, dataset, n_methods: int, n_thresholds: int,
                   n_versions: int) -> list[SequenceTotals]:
    """The parts' arrays cut back into sequences, every shape and range checked."""
    n_sequences, n_frames = len(dataset.sequences), dataset.n_frames
    counts = sharding.merged_array("cat_counts", (n_sequences, n_methods, n_thresholds, 3), "i", within=(0, 1 << 40))
    temporal = sharding.merged_array("cat_temporal", (n_sequences, n_methods, n_thresholds, 3), "i",
                                     within=(0, 1 << 40))
    miou = sharding.merged_array("cat_miou", (n_sequences, n_methods), "f", within=(0.0, 1.0))
    acc = sharding.merged_array("cat_acc", (n_frames, n_methods, n_versions, 4), "f", within=(-1e6, 1e6))  # FP < 0
    outside = sharding.merged_array("cat_truth_outside", (n_frames,), "i", within=(0, 1))
    odd = sharding.merged_array("cat_odd_masks", (n_frames, n_methods), "i", within=(0, 1))
    totals, first = [], 0
    for s, frames in enumerate(dataset.sequences.values()):
        end = first + len(frames)
        totals.append(SequenceTotals(counts[s], temporal[s], miou[s], acc[first:end], outside[first:end],
                                     odd[first:end]))
        first = end
    return totals


def _size_warnings(dataset, totals: Sequence[SequenceTotals], trees) -> list[str]:
    """Said when a sequence's size looks wrong: the ground truth of half its frames or more reaching
    past it (a lane may leave the image now and then), or masks of another size."""
    out = []
    for (name, size), piece in zip(dataset.sizes.items(), totals):
        frames = dataset.sequences[name]
        outside = [relpath for relpath, flag in zip(frames, piece.truth_outside) if flag]
        if 2 * len(outside) >= len(frames) > 0:
            out.append(f"warning: {name}: the ground truth of {len(outside)} frames reaches beyond its "
                       f"{size[0]}x{size[1]} size (first: {outside[0]}): is the size right?")
        for m, tree in enumerate(trees):
            odd = [relpath for relpath, flag in zip(frames, piece.odd_masks[:, m]) if flag]
            if odd:
                out.append(f"warning: {tree.method}: {len(odd)} masks of {name} are not {size[0]}x{size[1]} (first: "
                           f"{odd[0]}); each is read at its own size, as generate_iou_pred_txt.py reads it")
    return out


def official_rows(names: Sequence[str], methods: Sequence[str], totals: Sequence[SequenceTotals],
                  thresholds: Thresholds):
    """official.csv's rows (per sequence, per scenario, then 'all', at each threshold) and the
    pooled 'all' score per (method, threshold label)."""
    rows, overall = [], {}
    for m, method in enumerate(methods):
        for t, label in enumerate(thresholds.labels):
            per_sequence = [piece.sequence_score(name, m, t) for name, piece in zip(names, totals)]
            for score in per_sequence:
                rows.append(_row(method, score.sequence, label, score.tp, score.fp, score.fn, score.miou, 1))
            for code in range(len(SCENARIOS)):
                members = [s for s in per_sequence if code in scenarios_of(s.sequence)]
                if members:
                    group = pooled(members)
                    rows.append(_row(method, _scenario_name(code), label, group.tp, group.fp, group.fn,
                                     group.miou, group.sequences))
            every = pooled(per_sequence)
            overall[(method, label)] = every
            rows.append(_row(method, "all", label, every.tp, every.fp, every.fn, every.miou, every.sequences))
    return rows, overall


def temporal_rows(names: Sequence[str], methods: Sequence[str], totals: Sequence[SequenceTotals],
                  thresholds: Thresholds):
    """temporal.csv's rows: per sequence, per scenario (its sequences' pairs pooled) and all."""
    rows, overall = [], {}
    for m, method in enumerate(methods):
        for t, label in enumerate(thresholds.labels):
            per_sequence = {name: piece.temporal_counts(m, t) for name, piece in zip(names, totals)}
            rows += [_temporal_row(method, name, label, counts) for name, counts in per_sequence.items()]
            for code in range(len(SCENARIOS)):
                members = [counts for name, counts in per_sequence.items() if code in scenarios_of(name)]
                if members:
                    pooled_counts = sum(members, TemporalCounts())
                    rows.append(_temporal_row(method, _scenario_name(code), label, pooled_counts))
            every = sum(per_sequence.values(), TemporalCounts())
            overall[(method, label)] = every
            rows.append(_temporal_row(method, "all", label, every))
    return rows, overall


def acc_rows(names: Sequence[str], methods: Sequence[str], totals: Sequence[SequenceTotals],
             versions: Sequence[str]):
    """acc.csv's rows (per sequence, per scenario, all; RVLD's version, and MMA-Net's where the
    predictions are instance masks) and the 'all' means per (method, version). A group's figures
    are means over its frames, as the scripts divide their sums by the number of frames."""
    rows, overall = [], {}
    for m, method in enumerate(methods):
        for v, version in enumerate(versions):
            per_sequence = {name: piece.acc_frames(m, v) for name, piece in zip(names, totals)}
            groups = [(name, frames) for name, frames in per_sequence.items()]
            for code in range(len(SCENARIOS)):
                members = [frame for name, frames in per_sequence.items() if code in scenarios_of(name)
                           for frame in frames]
                if members:
                    groups.append((_scenario_name(code), members))
            every = [frame for frames in per_sequence.values() for frame in frames]
            groups.append(("all", every))
            for category, frames in groups:
                result = acc_means(frames)
                rows.append((method, category, version, result.frames, result.accuracy, result.fp, result.fn,
                             result.stopping))
            overall[(method, version)] = acc_means(every)
    return rows, overall


def _temporal_row(method: str, category: str, label: str, counts: TemporalCounts) -> tuple:
    return (method, category, label, counts.pairs, counts.stable, counts.jump, counts.missing, *counts.rates)


def _row(method: str, category: str, label: str, tp: int, fp: int, fn: int, miou: float, sequences: int) -> tuple:
    return (method, category, label, tp, fp, fn, *f_measure(tp, fp, fn), float(miou), sequences)



def summary_table(score: Vil100Score) -> str:
    """Markdown: per method, F1 (%) at each threshold and mIoU (%), over every sequence."""
    labels = score.thresholds.labels
    temporal = [(label, name) for label in labels for name in ("Rs", "Rj", "Rm")] if score.temporal_overall else []
    versions = [version for version in ACC_VERSIONS if any(key[1] == version for key in score.acc_overall)]
    acc = [f" {name} ({_ACC_SOURCES[version]}) {unit}|" for version in versions
           for name, unit in (("Acc", "(%) "), ("FP", ""), ("FN", ""))]
    lines = ["| method | " + " | ".join(f"F1@{label} (%)" for label in labels) + " | mIoU (%) |"
             + "".join(f" {name}@{label} (%) |" for label, name in temporal) + "".join(acc),
             "|---" * (len(labels) + 2 + len(temporal) + len(acc)) + "|"]
    lines += [_summary_line(score, method, bool(temporal), versions) for method in score.methods]
    return "\n".join(lines)


def _summary_line(score: Vil100Score, method: str, temporal: bool, versions: list[str]) -> str:
    """A method's row of summary.md: F1 at each threshold, mIoU, the temporal rates and Acc."""
    labels = score.thresholds.labels
    results: list[PooledScore] = [score.overall[(method, label)] for label in labels]
    f1s = [percent(result.ratios[2]) for result in results]
    rates = [percent(rate) for label in labels if temporal for rate in score.temporal_overall[(method, label)].rates]
    accs = [text for version in versions for text in _acc_cells(score.acc_overall.get((method, version)))]
    return (f"| {method} | " + " | ".join(f1s) + f" | {percent(results[0].miou)} |"
            + "".join(f" {rate} |" for rate in rates) + "".join(f" {text} |" for text in accs))


_ACC_SOURCES = {"mmanet": "MMA-Net", "rvld": "RVLD"}
# Said beside RVLD's Acc wherever it is printed (metrics.vil100_acc: the writer's rule)
RVLD_ACC_NOTE = ("Acc (RVLD) reads each lane as RVLD's writer (libs/save_prediction.py, 4d90de1) would have "
                 "written it, the only lanes its script reads: the first point at each y, and a lane of 3 points "
                 "or fewer (a blank line too) is no prediction.")


def _acc_cells(result) -> list[str]:
    if result is None:
        return ["n/a"] * 3
    return [percent(result.accuracy), f"{result.fp:.4f}", f"{result.fn:.4f}"]


def summary_rows(score: Vil100Score) -> PlainTable:
    """The numbers papers print, per method for all sequences and each scenario: F1 at each
    threshold, mIoU, and Rs, Rj, Rm with each threshold as tau (fractions, as official.csv)."""
    labels = score.thresholds.labels
    official = _keyed(score.rows)
    temporal = _keyed(score.temporal_rows)
    acc = _keyed(score.acc_rows)
    versions = [version for version in ACC_VERSIONS if any(key[2] == version for key in acc)]
    rows = []
    for method in score.methods:
        for category in _summary_categories(score):
            row = [method, category, *(official[(method, category, label)][8] for label in labels),
                   official[(method, category, labels[0])][9]]
            if temporal:
                row += [value for label in labels for value in temporal[(method, category, label)][7:10]]
            row += _acc_values(acc, method, category, versions)
            rows.append(tuple(row))
    return PlainTable(_summary_columns(labels, bool(temporal), versions), tuple(rows))


def _summary_columns(labels: tuple[str, ...], temporal: bool, versions: list[str]) -> tuple[str, ...]:
    columns = ["method", "category", *(f"f1@{label}" for label in labels), "miou"]
    if temporal:
        columns += [f"{name}@{label}" for label in labels for name in ("rs", "rj", "rm")]
    return tuple(columns + [f"{name}_{version}" for version in versions for name in ("acc", "fp", "fn")])


def _summary_categories(score: Vil100Score) -> list[str]:
    """'all' first, then each scenario, as official.csv has them."""
    categories = list(dict.fromkeys(r[1] for r in score.rows.rows if r[1] == "all" or r[1].startswith("scenario ")))
    return categories[-1:] + categories[:-1]


def _keyed(table: PlainTable | None) -> dict[tuple, tuple]:
    """A table's rows by (method, category, threshold or version); none without the table."""
    return {} if table is None else {(r[0], r[1], r[2]): r for r in table.rows}


def _acc_values(acc: dict[tuple, tuple], method: str, category: str, versions: list[str]) -> list:
    """Acc, FP and FN of each version (NaN where it has no row)."""
    values: list = []
    for version in versions:
        found = acc.get((method, category, version))
        values += [math.nan] * 3 if found is None else list(found[4:7])
    return values


def summary_markdown(score: Vil100Score, width: int) -> str:
    return (f"# VIL-100, official protocol\n\n{score.n_frames:,} frames of {score.n_sequences} sequences, each at its "
            f"own size; lanes {width} px wide; a match counts when IoU > the threshold (MMA-Net's evaluate_iou.py "
            "and CULane evaluator, 8f95908). F1 from TP, FP and FN summed over the sequences; mIoU: the mean "
            "over sequences of each sequence's mIoU as its evaluator prints it (6 significant digits), a frame's "
            "mIoU being the IoU summed over the matched pairs divided by its predicted lanes. official.csv "
            "gives every sequence and scenario."
            + (" Rs, Rj, Rm: RVLD's evaluate_temporal.py (4d90de1) with each threshold as tau, over the pairs of "
               "ground-truth lanes linked across consecutive frames (IoU > 0.5), with that script's own IoU; a frame "
               "without a prediction file counts as no lanes, where that script stops. temporal.csv gives every "
               "sequence." if score.temporal_overall else "")
            + (" Acc, FP, FN: TuSimple's rule over at most 8 lanes a frame, means over frames, in two versions: "
               "MMA-Net's evaluate_acc.py (8f95908: each instance mask's lane fitted by a degree-2 polynomial; only "
               "with --pred-format png) and RVLD's evaluate_acc.py (4d90de1: each lane's points through a cubic "
               f"interp1d); a frame without ground truth scores accuracy 0 in both. {RVLD_ACC_NOTE} Lanes where a "
               "script would stop (acc.csv's stopping_lanes): RVLD's, as given, at two points at one y or 3 points "
               "or fewer, MMA-Net's where its polyfit fails (that mask lane matches no point). "
               "acc.csv gives every sequence and scenario." if score.acc_overall else "")
            + "\n\n" + summary_table(score) + "\n")


__all__ = ["score_vil100", "Vil100Score", "SequenceScore", "printed"]


def _only(dataset: Vil100Set, frames: Collection[str] | None, shard: str | None) -> Vil100Set:
    """The set with only `frames` of it (a run's own: run --diagnose), sequences keeping their order."""
    if frames is None:
        return dataset
    kept = set(only_frames([r for listed in dataset.sequences.values() for r in listed], frames, shard))
    sequences = {name: tuple(r for r in listed if r in kept) for name, listed in dataset.sequences.items()}
    sequences = {name: listed for name, listed in sequences.items() if listed}
    return replace(dataset, sequences=sequences, sizes={name: dataset.sizes[name] for name in sequences},
                   unlabelled=tuple(r for r in dataset.unlabelled if r in kept))


def diagnose_run(lanes: Path, dataset, frames: Iterable[str], config, loc_iou: float | None,
                 announce: Callable[[str], None] | None = None) -> Diagnosed:
    """`run --diagnose`: the lanes the run saved (`lanes`) scored as `score vil100 --diagnose`
    scores them, at the run's thresholds and lane width, over the frames it scored (`frames`)."""
    from .benchmark import THRESHOLDS
    from .reader import run_sources

    sources = run_sources(dataset.root, None if config.dataset.list_file is None else Path(config.dataset.list_file))
    score = score_vil100(sources.labels, lanes, sources.list_file, sources.image_root, sources.json_root,
                         sources.sizes_file, iou=THRESHOLDS, width=config.official.lane_width_px,
                         workers=config.workers, announce=announce, temporal=False, diagnose=True, loc_iou=loc_iou,
                         frames=[image_stem(frame) for frame in frames])
    assert score is not None and score.diagnosed is not None
    return score.diagnosed
