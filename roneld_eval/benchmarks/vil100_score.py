"""`score vil100`: predicted `.lines.txt` files scored as MMA-Net's evaluation/evaluate_iou.py and
its modified CULane evaluator score them (yujun0-0/MMA-Net 8f95908), every method in one pass
over the ground truth, every threshold at once (the C++ tool needs one run per sequence and
threshold). Sequences are scored at their own size, in parallel.
"""

from __future__ import annotations

import math

import numpy as np
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Sequence

from ..config import check_lane_width

from ..thresholds import Thresholds, parse_thresholds
from ..datasets.culane import check_inside
from ..datasets.vil100 import SCENARIOS, labels_path, read_vil100, scenarios_of
from ..datasets._paths import under_root
from ..errors import ConfigError, InputError
from ..model import image_stem
from ..lanes_io import check_coordinates, read_culane_lines
from ..metrics.culane_official import CulaneFrameResult, evaluate_culane_frame, f_measure, official_masks
from ..metrics.vil100_acc import AccFrame, mmanet_frame, rvld_frame
from ..metrics.vil100_acc import means as acc_means
from ..metrics.vil100_official import PooledScore, SequenceScore, frame_miou, pooled, printed, sequence_score
from ..metrics.vil100_temporal import TemporalCounts, assigned_ious, lane_mask, links, sequence_counts, usable
from ..output import Staging
from ..score import PlainTable, PredictionRoots, _taking, find_prediction_trees, percent, scored_pieces

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


@dataclass
class ScoredSequence:
    """One sequence against every method: per method, each frame's matched result and mIoU;
    with the temporal metrics, the ground truth's links between consecutive frames and, per
    method, each frame's assigned IoUs (RVLD's own IoU)."""

    frames: list[list[tuple[CulaneFrameResult, float]]]
    links: list[list[tuple[int, int]]] = field(default_factory=list)
    assigned: list[list[np.ndarray]] = field(default_factory=list)
    # per method, each frame's Acc/FP/FN: RVLD's version, and MMA-Net's (None without instance masks)
    acc: list[list[tuple[AccFrame, AccFrame | None]]] = field(default_factory=list)
    # frames whose ground truth reaches beyond the sequence's size (a wrong size?); per method,
    # masks of another size than the sequence's (the script reads them at their own)
    truth_outside: list[str] = field(default_factory=list)
    odd_masks: list[list[str]] = field(default_factory=list)


PRED_FORMATS = ("lines", "png")  # .lines.txt, or MMA-Net's instance masks (datasets.vil100_png)
_SUFFIXES = {"lines": ".lines.txt", "png": ".png"}


def _read_predictions(root: Path, relpath: str, pred_format: str):
    """(lanes, the instance mask's fits and height, or None for lane files)."""
    if pred_format == "png":
        from ..datasets.vil100_png import read_instance_png

        mask = read_instance_png(under_root(root, f"{image_stem(relpath)}.png"))
        return mask.lanes, mask
    path = labels_path(root, relpath)
    predictions = read_culane_lines(path)
    check_coordinates(predictions, path)
    return predictions, None


def _score_sequence(args) -> ScoredSequence:
    relpaths, labels, pred_roots, width, height, lane_width, temporal, pred_format = args
    out = ScoredSequence([[] for _ in pred_roots], [], [[] for _ in pred_roots], [[] for _ in pred_roots], [],
                         [[] for _ in pred_roots])
    previous: list | None = None
    for relpath in relpaths:
        path = labels_path(labels, relpath)
        truth = read_culane_lines(path)  # a missing file: no lanes, as the C++ reader ("fail")
        check_inside(truth, path, width, height)
        if any(((lane.xs > width + 1) | (lane.ys > height + 1)).any() for lane in truth):
            out.truth_outside.append(relpath)
        gt_masks = official_masks(truth, width, height, lane_width) if truth else None
        if temporal:
            linked = [lane_mask(lane, width, height) for lane in usable(truth)]
            out.links.append([] if previous is None else links(linked, previous))
            previous = linked
        for m, root in enumerate(pred_roots):
            predictions, mask = _read_predictions(root, relpath, pred_format)
            if mask is not None and mask.height is not None and (mask.width, mask.height) != (width, height):
                out.odd_masks[m].append(relpath)
            result = evaluate_culane_frame(truth, predictions, width, height, lane_width, gt_masks=gt_masks)
            out.frames[m].append((result, frame_miou(result)))
            mmanet = None if mask is None else mmanet_frame(mask.fits, truth, mask.height or height)
            out.acc[m].append((rvld_frame(predictions, truth), mmanet))
            if temporal:
                drawn = [lane_mask(lane, width, height) for lane in usable(predictions)]
                out.assigned[m].append(assigned_ious(linked, drawn))
    return out


def score_vil100(labels: str | Path, pred_root: PredictionRoots, list_file: str | Path | None = None,
                 image_root: str | Path | None = None, json_root: str | Path | None = None,
                 sizes_file: str | Path | None = None, iou: str | None = None, width: int = LANE_WIDTH,
                 out: str | Path | None = None, workers: int | None = None, progress: bool = False,
                 announce: Callable[[str], None] | None = None, strict: bool = False,
                 temporal: bool = True, pred_format: str = "lines") -> Vil100Score:
    """Score `.lines.txt` predictions mirroring `labels` (`<sequence>/<frame>.lines.txt`).

    Sizes come from exactly one of `image_root`, `json_root` and `sizes_file`. `iou`: one
    threshold, a comma list or a grid (default 0.5 and 0.8). `temporal`: also RVLD's Rs, Rj and
    Rm with each threshold as tau. `pred_format`: "lines" (`.lines.txt`) or "png" (MMA-Net's
    instance masks `<sequence>/<frame>.png`, converted as its generate_iou_pred_txt.py converts
    them). `out` gets official.csv, temporal.csv, summary.csv and summary.md.
    """
    if pred_format not in PRED_FORMATS:
        raise ConfigError(f"prediction format must be one of {', '.join(PRED_FORMATS)}, got {pred_format!r}")
    thresholds = parse_thresholds(iou or DEFAULT_IOU)
    check_lane_width(width)
    with _taking(out, "score vil100") as folder:
        dataset = read_vil100(labels, list_file, image_root, json_root, sizes_file)
        relpaths = [relpath for frames in dataset.sequences.values() for relpath in frames]
        trees, warnings = find_prediction_trees(pred_root, relpaths, strict, announce, suffix=_SUFFIXES[pred_format])
        if dataset.unlabelled:
            first = labels_path(dataset.labels, dataset.unlabelled[0])
            said = (f"{len(dataset.unlabelled):,} of {len(relpaths):,} listed frames have no ground-truth file "
                    f"(first: {first})")
            if strict:
                raise InputError(dataset.labels, f"{said}; --strict needs every one")
            # Every VIL-100 test frame has one (40 are empty): a missing one is a wrong list or folder.
            warnings.insert(0, f"warning: {said}; they count as frames without lanes, as MMA-Net's evaluator "
                               "reads them")
        roots = tuple(tree.root for tree in trees)
        tasks = [(frames, dataset.labels, roots, *dataset.sizes[name], width, temporal, pred_format)
                 for name, frames in dataset.sequences.items()]
        scored = scored_pieces(_score_sequence, tasks, workers, progress, announce)
        warnings += _size_warnings(dataset, scored, trees)
        methods = tuple(tree.method for tree in trees)
        names = list(dataset.sequences)
        rows, overall = official_rows(names, methods, scored, thresholds)
        temporal_table, temporal_overall = (temporal_rows(names, methods, scored, thresholds) if temporal
                                            else ([], {}))
        acc_table, acc_overall = acc_rows(names, methods, scored)
        score = Vil100Score(PlainTable(COLUMNS, tuple(rows)),
                            PlainTable(TEMPORAL_COLUMNS, tuple(temporal_table)) if temporal else None,
                            thresholds, methods, len(relpaths), len(dataset.sequences), overall, temporal_overall,
                            PlainTable(ACC_COLUMNS, tuple(acc_table)), acc_overall, tuple(warnings))
        if folder is not None:
            staging = Staging(folder)
            staging.write_text("official.csv", score.rows.to_csv())
            if score.temporal_rows is not None:
                staging.write_text("temporal.csv", score.temporal_rows.to_csv())
            assert score.acc_rows is not None
            staging.write_text("acc.csv", score.acc_rows.to_csv())
            staging.write_text("summary.csv", summary_rows(score).to_csv())
            staging.write_text("summary.md", summary_markdown(score, width))
            folder.commit()
    return score


def _size_warnings(dataset, scored: Sequence[ScoredSequence], trees) -> list[str]:
    """Said when a sequence's size looks wrong: the ground truth of half its frames or more reaching
    past it (a lane may leave the image now and then), or masks of another size."""
    out = []
    for (name, size), piece in zip(dataset.sizes.items(), scored):
        if 2 * len(piece.truth_outside) >= len(piece.frames[0] if piece.frames else []) > 0:
            out.append(f"warning: {name}: the ground truth of {len(piece.truth_outside)} frames reaches beyond its "
                       f"{size[0]}x{size[1]} size (first: {piece.truth_outside[0]}): is the size right?")
        for tree, odd in zip(trees, piece.odd_masks):
            if odd:
                out.append(f"warning: {tree.method}: {len(odd)} masks of {name} are not {size[0]}x{size[1]} (first: "
                           f"{odd[0]}); each is read at its own size, as generate_iou_pred_txt.py reads it")
    return out


def official_rows(names: Sequence[str], methods: Sequence[str], scored: Sequence[ScoredSequence],
                  thresholds: Thresholds):
    """official.csv's rows (per sequence, per scenario, then 'all', at each threshold) and the
    pooled 'all' score per (method, threshold label)."""
    rows, overall = [], {}
    for m, method in enumerate(methods):
        for value, label in zip(thresholds.values, thresholds.labels):
            per_sequence = []
            for name, piece in zip(names, scored):
                frames = piece.frames[m]
                per_sequence.append(sequence_score(name, [r for r, _ in frames], [v for _, v in frames], value))
            for score in per_sequence:
                rows.append(_row(method, score.sequence, label, score.tp, score.fp, score.fn, score.miou, 1))
            for code, scenario in enumerate(SCENARIOS):
                members = [s for s in per_sequence if code in scenarios_of(s.sequence)]
                if members:
                    group = pooled(members)
                    rows.append(_row(method, f"scenario {code} ({scenario})", label, group.tp, group.fp, group.fn,
                                     group.miou, group.sequences))
            every = pooled(per_sequence)
            overall[(method, label)] = every
            rows.append(_row(method, "all", label, every.tp, every.fp, every.fn, every.miou, every.sequences))
    return rows, overall


def temporal_rows(names: Sequence[str], methods: Sequence[str], scored: Sequence[ScoredSequence],
                  thresholds: Thresholds):
    """temporal.csv's rows: per sequence, per scenario (its sequences' pairs pooled) and all."""
    rows, overall = [], {}
    for m, method in enumerate(methods):
        for value, label in zip(thresholds.values, thresholds.labels):
            per_sequence = {name: sequence_counts(piece.links, piece.assigned[m], value)
                            for name, piece in zip(names, scored)}
            rows += [_temporal_row(method, name, label, counts) for name, counts in per_sequence.items()]
            for code, scenario in enumerate(SCENARIOS):
                members = [counts for name, counts in per_sequence.items() if code in scenarios_of(name)]
                if members:
                    pooled_counts = sum(members, TemporalCounts())
                    rows.append(_temporal_row(method, f"scenario {code} ({scenario})", label, pooled_counts))
            every = sum(per_sequence.values(), TemporalCounts())
            overall[(method, label)] = every
            rows.append(_temporal_row(method, "all", label, every))
    return rows, overall


def acc_rows(names: Sequence[str], methods: Sequence[str], scored: Sequence[ScoredSequence]):
    """acc.csv's rows (per sequence, per scenario, all; RVLD's version, and MMA-Net's where the
    predictions are instance masks) and the 'all' means per (method, version). A group's figures
    are means over its frames, as the scripts divide their sums by the number of frames."""
    rows, overall = [], {}
    for m, method in enumerate(methods):
        for v, version in enumerate(ACC_VERSIONS):
            found = {name: [frame[1 - v] for frame in piece.acc[m]] for name, piece in zip(names, scored)}
            if any(frame is None for frames in found.values() for frame in frames):
                continue  # MMA-Net's version reads instance masks: not lane files
            per_sequence = {name: [frame for frame in frames if frame is not None] for name, frames in found.items()}
            groups = [(name, frames) for name, frames in per_sequence.items()]
            for code, scenario in enumerate(SCENARIOS):
                members = [frame for name, frames in per_sequence.items() if code in scenarios_of(name)
                           for frame in frames]
                if members:
                    groups.append((f"scenario {code} ({scenario})", members))
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
    for method in score.methods:
        results: list[PooledScore] = [score.overall[(method, label)] for label in labels]
        f1s = [percent(result.ratios[2]) for result in results]
        rates = [percent(rate) for label in labels if temporal
                 for rate in score.temporal_overall[(method, label)].rates]
        accs = [text for version in versions for text in _acc_cells(score.acc_overall.get((method, version)))]
        lines.append(f"| {method} | " + " | ".join(f1s) + f" | {percent(results[0].miou)} |"
                     + "".join(f" {rate} |" for rate in rates) + "".join(f" {text} |" for text in accs))
    return "\n".join(lines)


_ACC_SOURCES = {"mmanet": "MMA-Net", "rvld": "RVLD"}


def _acc_cells(result) -> list[str]:
    if result is None:
        return ["n/a"] * 3
    return [percent(result.accuracy), f"{result.fp:.4f}", f"{result.fn:.4f}"]


def summary_rows(score: Vil100Score) -> PlainTable:
    """The numbers papers print, per method for all sequences and each scenario: F1 at each
    threshold, mIoU, and Rs, Rj, Rm with each threshold as tau (fractions, as official.csv)."""
    labels = score.thresholds.labels
    official = {(r[0], r[1], r[2]): r for r in score.rows.rows}
    temporal = {} if score.temporal_rows is None else {(r[0], r[1], r[2]): r for r in score.temporal_rows.rows}
    columns = ["method", "category", *(f"f1@{label}" for label in labels), "miou"]
    if temporal:
        columns += [f"{name}@{label}" for label in labels for name in ("rs", "rj", "rm")]
    acc = {} if score.acc_rows is None else {(r[0], r[1], r[2]): r for r in score.acc_rows.rows}
    versions = [version for version in ACC_VERSIONS if any(key[2] == version for key in acc)]
    columns += [f"{name}_{version}" for version in versions for name in ("acc", "fp", "fn")]
    categories = list(dict.fromkeys(r[1] for r in score.rows.rows if r[1] == "all" or r[1].startswith("scenario ")))
    categories = categories[-1:] + categories[:-1]  # all first
    rows = []
    for method in score.methods:
        for category in categories:
            row = [method, category, *(official[(method, category, label)][8] for label in labels),
                   official[(method, category, labels[0])][9]]
            if temporal:
                row += [value for label in labels for value in temporal[(method, category, label)][7:10]]
            for version in versions:
                found = acc.get((method, category, version))
                row += [math.nan] * 3 if found is None else list(found[4:7])
            rows.append(tuple(row))
    return PlainTable(tuple(columns), tuple(rows))


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
               "interp1d); a frame without ground truth scores accuracy 0 in both. Where a script stops on a lane "
               "(acc.csv's stopping_lanes): RVLD's at two points at one y (the first is kept here) or fewer than 4 "
               "(it matches no point here), MMA-Net's where its polyfit fails (it matches no point). "
               "acc.csv gives every sequence and scenario." if score.acc_overall else "")
            + "\n\n" + summary_table(score) + "\n")


__all__ = ["score_vil100", "Vil100Score", "SequenceScore", "printed"]
