"""`score culane`: the official CULane scores of lane files, as SCNN's tools/lane_evaluation computes them.

Every prediction tree (one method each) is scored in one pass over the ground truth: each
frame's labels are read and drawn once (or taken from the ground-truth cache), then matched
against every method's lanes. The matched IoUs are kept, so a whole threshold grid (CLRNet's mF1:
0.50..0.95) costs no second pass. Prediction roots are checked before any work: a root where no
file of the list is stops with the path looked for and the folder that would match.

Start-up matters here (one frame should score in well under a second): the tables are plain
tuples written with the csv module, byte for byte what pandas' to_csv wrote, and pandas is
imported only when a DataFrame is asked for (CulaneScore.official, .summary, .table).
"""

from __future__ import annotations

import os
from collections.abc import Collection, Iterable, Mapping, Sequence
from dataclasses import dataclass, replace
from functools import cached_property, partial
from pathlib import Path
from typing import TYPE_CHECKING, Callable, Iterator

import numpy as np

from ...config import check_lane_width

from ...thresholds import Thresholds, parse_thresholds
from .reader import IMAGE_HEIGHT, IMAGE_WIDTH, read_culane
from .reader import labels_path, read_frame_labels
from ...errors import ConfigError, InputError
from ...lanes_io import check_coordinates, read_lines_txt, read_scores_beside
from ...metrics.lane_iou_f1 import (
    OFFICIAL_COLUMNS,
    FrameMatches,
    GroupCounts,
    ScoredFrames,
    frame_result,
    frame_similarity,
    highlight_name,
    highlighted,
    official_masks,
    summary_records,
)
from ...metrics.lane_errors import (DiagnosisCollector, DiagnosisSettings, FrameDiagnoses, FrameErrors,
                                    diagnosis_part, diagnosis_settings, diagnoses_merged, joined_diagnoses,
                                    kernel_groups)
from ...report.diagnosis import Diagnosed, write_diagnosis
from ...report.gallery import GalleryFrame
from ...output import OutputFolder
from ...report.tables import Table
from ...output import Staging
from ... import truth_cache
from ...truth_cache import TruthRuns

if TYPE_CHECKING:
    import pandas as pd

    from ...metrics.raster import MaskSet

from ...scoring import (PlainTable, PredictionRoots, PredictionTree, _taking, check_still_there, find_prediction_trees,
                        only_frames, percent)


@dataclass(frozen=True)
class ScorePreset:
    """A threshold grid as a paper family reports it, and the thresholds its tables single out."""

    iou: str
    highlighted: tuple[str, ...]
    source: str


SCORE_PRESETS = {
    # CLRNet README (mF1, F1@50, F1@75) and clrnet/datasets/culane.py: np.linspace(0.5, 0.95, 10).
    "clrnet": ScorePreset("0.50:0.95:0.05", ("0.50", "0.75"), "CLRNet: mF1 over IoU 0.50:0.95:0.05, F1@50, F1@75"),
}


CHUNK_FRAMES = 200


@dataclass(frozen=True)
class CulaneScore:
    """Official CULane scores of one or more prediction trees (methods) over a threshold grid.

    `official` and `summary` give the tables as DataFrames (importing pandas on first use);
    `official_rows` and `summary_rows` are the same tables as plain rows.
    """

    official_rows: PlainTable  # method, category, threshold, tp, fp, fn, precision, recall, f1
    summary_rows: PlainTable  # method, category, F1@50 / F1@75 (those in the grid), mF1 (grids of 2+)
    thresholds: Thresholds
    highlighted: tuple[str, ...]  # threshold labels the summary shows one by one
    trees: tuple[PredictionTree, ...]
    n_frames: int
    warnings: tuple[str, ...] = ()  # e.g. a root where fewer than half the listed frames have a file
    ground_truth: str = ""  # digest of the frames scored and their categories (sweep.json: what compare checks)
    sweep: bool = False  # checkpoints (a glob, a list file), not methods: sweep.csv names the best
    diagnosed: Diagnosed | None = None  # --diagnose, --score-sweep: error types, frames, score sweep

    @property
    def methods(self) -> tuple[str, ...]:
        return tuple(tree.method for tree in self.trees)

    @cached_property
    def official(self) -> pd.DataFrame:
        """method, category, threshold, tp, fp, fn, precision, recall, f1 (official.csv)."""
        return self.official_rows.to_frame()

    @cached_property
    def summary(self) -> pd.DataFrame:
        """method, category, F1@50 / F1@75 (those in the grid), mF1 (grids of 2+) (summary.csv)."""
        return self.summary_rows.to_frame()

    @property
    def first_rows(self) -> PlainTable:
        """The rows at the first threshold: method, category, tp, fp, fn, precision, recall, f1."""
        at = OFFICIAL_COLUMNS.index("threshold")
        return PlainTable(self.official_rows.columns[:at] + self.official_rows.columns[at + 1:],
                          tuple(row[:at] + row[at + 1:] for row in self.official_rows.rows
                                if row[at] == self.thresholds.labels[0]))

    @property
    def table(self) -> pd.DataFrame:
        """The rows at the first threshold: method, category, tp, fp, fn, precision, recall, f1."""
        first = self.official[self.official["threshold"] == self.thresholds.labels[0]]
        return first.drop(columns="threshold").reset_index(drop=True)


def _score_frames(args) -> tuple[np.ndarray, np.ndarray, np.ndarray, TruthRuns | None, FrameDiagnoses | None]:
    """One chunk of frames against every method: (n_gt, n_pred per method, matched IoUs per
    method, the ground truth as drawn when `keep_truth`, and with `diagnosis` each frame's error
    types and score sweep). `truth`: (a checked entry of the ground-truth cache, the chunk's first
    frame in it) to take the frames' drawn lanes from."""
    relpaths, data_root, pred_roots, width, height, lane_width, truth, keep_truth, diagnosis = args
    cached = None if truth is None else truth_cache.open_entry(truth[0])
    n_gt = np.zeros(len(relpaths), np.int64)
    n_pred = np.zeros((len(pred_roots), len(relpaths)), np.int64)
    ious: list[list[np.ndarray]] = [[] for _ in pred_roots]
    drawn: list[tuple[int, MaskSet | None]] = []
    diagnosed = DiagnosisCollector(diagnosis, len(pred_roots))
    for k, relpath in enumerate(relpaths):
        gt_masks: MaskSet | None
        if cached is not None:
            n_gt[k], gt_masks = cached.frame(truth[1] + k)
        else:
            lanes = read_frame_labels(data_root, relpath)
            n_gt[k] = len(lanes)
            gt_masks = official_masks(lanes, width, height, lane_width) if lanes else None  # drawn once, for all
            if keep_truth:
                drawn.append((len(lanes), gt_masks))
        for m, pred_root in enumerate(pred_roots):
            path = labels_path(pred_root, relpath)
            predictions = read_lines_txt(path)
            check_coordinates(predictions, path)
            result = _method_frame(int(n_gt[k]), gt_masks, predictions, path, (width, height, lane_width),
                                   diagnosed, m)
            n_pred[m, k] = result.n_pred
            ious[m].append(result.matched_iou)
    matched = np.array([np.concatenate(parts) if parts else np.zeros(0) for parts in ious], np.float64)
    kept = truth_cache.from_frames(drawn) if keep_truth and cached is None else None
    return n_gt, n_pred, matched.reshape(len(pred_roots), int(n_gt.sum())), kept, diagnosed.result(relpaths)


def _method_frame(n_gt: int, gt_masks: MaskSet | None, predictions, path: Path, size: tuple[int, int, int],
                  diagnosed: DiagnosisCollector, m: int) -> FrameMatches | FrameErrors:
    """A method's frame: frame_result, or with a diagnosis its FrameErrors (the same matched IoUs),
    its error types and score sweep collected by `diagnosed`."""
    if diagnosed.settings is None:
        return frame_result(n_gt, gt_masks, predictions, *size)
    errors = diagnosed.add(m, partial(frame_similarity, n_gt, gt_masks, predictions, *size),
                           partial(read_scores_beside, path, len(predictions)))
    assert errors is not None
    return errors


def _thresholds(iou: str | float | None, preset: str | None) -> tuple[Thresholds, tuple[str, ...]]:
    """The grid and the thresholds the summary singles out (0.50 and 0.75 when in the grid)."""
    if preset is not None:
        if preset not in SCORE_PRESETS:
            raise ConfigError(f"unknown preset {preset!r}; choose from {', '.join(SCORE_PRESETS)}")
        if iou is not None and parse_thresholds(str(iou)) != parse_thresholds(SCORE_PRESETS[preset].iou):
            raise ConfigError(f"--preset {preset} is IoU {SCORE_PRESETS[preset].iou}; it contradicts --iou {iou}")
        thresholds = parse_thresholds(SCORE_PRESETS[preset].iou)
        return thresholds, SCORE_PRESETS[preset].highlighted
    thresholds = parse_thresholds(str(0.5 if iou is None else iou))
    return thresholds, highlighted(thresholds.labels)


def score_culane(data_root: str | Path, pred_root: PredictionRoots, list_file: str | Path | None = None,
                 iou: str | float | None = None, width: int = 30, out: str | Path | None = None,
                 workers: int | None = None, progress: bool = False,
                 announce: Callable[[str], None] | None = None, preset: str | None = None,
                 strict: bool = False, shard: str | None = None, diagnose: bool = False,
                 loc_iou: float | None = None, score_sweep: str | None = None,
                 frames: Collection[str] | None = None) -> CulaneScore | None:
    """Score `.lines.txt` predictions with the official CULane protocol, every method in one pass.

    `pred_root`: a folder mirroring the list, a folder of such folders (one per method), or
    several ('NAME=DIR' names one); a glob pattern, or sweeps.roots_from_file's roots, are
    checkpoints, named by what tells their paths apart, whose sweep is written too. `iou`: one
    threshold (default 0.5) or a grid scored in one pass ('0.50:0.95:0.05'); `preset='clrnet'`
    is that grid with F1@50/F1@75/mF1.
    A missing prediction file means no lanes (`strict`: an error). `out` gets official.csv,
    summary.csv and summary.md; with `shard` ('I/N', see roneld_eval.shards) only that share
    of the clips is scored and `out` gets its part for `merge` (None is returned).
    `diagnose`: also each error type's count and dF1 (errors.csv, errors.md, errors.png; a Loc when
    a false positive's IoU with its lane is at least `loc_iou`, default 0.1) and every frame's
    counts (frames.csv.gz); `score_sweep` ('0.00:0.95:0.05'): precision, recall and F1 with only
    the lanes whose `.scores.txt` score is at least each threshold (sweep_scores.csv, .png).
    """
    from ...shards import parse_shard

    thresholds, highlighted = _thresholds(iou, preset)
    check_lane_width(width)
    share = parse_shard(shard) if shard is not None else None
    diagnosis = diagnosis_settings(diagnose, loc_iou, score_sweep, thresholds.values)
    pred_root, sweep = _expanded_roots(pred_root)
    if share is not None and out is None:
        raise ConfigError("--shard writes a partial result for `roneld-eval merge`: give --out")
    with _taking(out, "score culane", reads=(data_root, list_file)) as folder:
        dataset = read_culane(data_root, list_file, labels=False, require_labels=True)
        relpaths = only_frames([frame.relpath for clip in dataset.clips for frame in clip.frames], frames, shard)
        # every shard finds the methods over the whole list: the same trees (and counts) in every part
        trees, warnings = find_prediction_trees(pred_root, relpaths, strict, announce)
        scored_relpaths = _share_of(dataset, share) if share is not None else relpaths
        say = announce or (lambda message: None)
        key, truth, kept = _truth_entry(dataset, scored_relpaths, width, say)
        diagnosed: list[FrameDiagnoses] = []
        pieces = _culane_pieces(scored_relpaths, dataset, trees, width, workers, progress, announce, truth, kept,
                                diagnosis, diagnosed)
        if share is not None:
            assert folder is not None
            joined = _joined(pieces, len(trees))
            _keep_truth(key, kept, say)
            recorded = _recorded_diagnosis(diagnosis, diagnose, loc_iou, score_sweep, dataset.root)
            _write_culane_part(folder, share, joined, dataset, relpaths, trees, warnings, iou, preset, width, strict,
                               sweep, recorded, diagnosis_part(diagnosis, joined_diagnoses(diagnosed), len(trees)))
            return None
        score = _culane_score(pieces, dataset.categories, thresholds, highlighted, trees, len(relpaths), warnings,
                              _culane_ground_truth(relpaths, dataset.categories), sweep)
        score = _with_diagnosis(score, joined_diagnoses(diagnosed), dataset.categories, dataset.root, width,
                                diagnosis)
        _keep_truth(key, kept, say)
        if folder is not None:
            write_culane_score(folder, score, width)
    return score


def _expanded_roots(pred_root: PredictionRoots) -> tuple[PredictionRoots, bool]:
    """The roots with glob patterns expanded (one checkpoint per folder matched), and whether
    they are a sweep of checkpoints."""
    from ...sweeps import expand_roots, is_sweep

    if isinstance(pred_root, Mapping):
        return pred_root, False
    roots = expand_roots([pred_root] if isinstance(pred_root, (str, Path)) else list(pred_root))
    return roots, is_sweep(roots)


def _share_of(dataset, share) -> list[str]:
    """The frames of a shard's share of the clips."""
    from ...shards import shard_range

    cut = shard_range([len(c.frames) for c in dataset.clips], share)
    return [frame.relpath for clip in dataset.clips[cut.start:cut.stop] for frame in clip.frames]


def _truth_entry(dataset, relpaths: list[str], width: int, say) -> tuple[str | None, Path | None,
                                                                          list[TruthRuns] | None]:
    """(key, entry, kept) of the ground-truth cache for these frames: the entry where it holds
    them, else a list to keep them in as they are drawn (None where the cache is off)."""
    if not truth_cache.enabled():
        return None, None, None
    key = truth_cache.truth_key(dataset.root, relpaths, dataset.image_width, dataset.image_height, width,
                                labels_path)
    truth = truth_cache.load(key, len(relpaths), dataset.image_width, dataset.image_height, say)
    return key, truth, ([] if truth is None else None)


def _culane_pieces(relpaths: list[str], dataset, trees, width: int, workers: int | None, progress: bool,
                   announce, truth: Path | None = None, kept: list[TruthRuns] | None = None,
                   diagnosis: DiagnosisSettings | None = None,
                   diagnosed: list[FrameDiagnoses] | None = None) -> Iterator[ScoredFrames]:
    """Every method's frame results on these frames, chunk after chunk, in their order. `truth`:
    a checked entry of the ground-truth cache holding these frames; else, with `kept` given, the
    ground truth as drawn is appended to it chunk by chunk. With `diagnosis`, each chunk's error
    types are appended to `diagnosed`."""
    image_width, image_height = dataset.image_width, dataset.image_height
    roots = tuple(tree.root for tree in trees)
    chunks = [relpaths[i:i + CHUNK_FRAMES] for i in range(0, len(relpaths), CHUNK_FRAMES)]
    tasks = [(chunk, dataset.root, roots, image_width, image_height, width,
              None if truth is None else (str(truth), i * CHUNK_FRAMES), kept is not None, diagnosis)
             for i, chunk in enumerate(chunks)]
    if len(chunks) > 1:  # a pool only for more than one chunk: a small set starts without multiprocessing
        from ...workers import worker_count

        workers = min(worker_count(workers), len(chunks))
    else:
        workers = 1
    from ... import kernels

    needed = kernel_groups(("official",), diagnosis)
    kernels.prepare(announce=announce, needed=needed)  # once here, not in every worker
    if workers == 1:
        kernels.warm_up(needed)  # loaded here in one go (start-up: see kernels.warm_up), not frame by frame
    from ...progress import progress_bar

    with progress_bar(len(relpaths), "frame", "scoring", wanted=progress) as bar:
        if workers > 1:
            from ...workers import process_pool, stopping

            died = "a worker process died (killed, or out of memory) while scoring: no result was written"
            with stopping(process_pool(workers), lambda: died) as pool:
                for chunk, piece in zip(chunks, pool.map(_score_frames, tasks)):
                    bar.update(len(chunk))
                    yield _piece(chunk, piece, kept, diagnosed)
        else:
            for chunk, task in zip(chunks, tasks):
                piece = _score_frames(task)
                bar.update(len(chunk))
                yield _piece(chunk, piece, kept, diagnosed)
    check_still_there(trees)  # before the last piece is taken in: nothing is written yet


def _piece(chunk: list[str], piece: tuple, kept: list[TruthRuns] | None,
           diagnosed: list[FrameDiagnoses] | None) -> ScoredFrames:
    n_gt, n_pred, matched, truth, diagnoses = piece
    if kept is not None and truth is not None:
        kept.append(truth)
    if diagnosed is not None and diagnoses is not None:
        diagnosed.append(diagnoses)
    return ScoredFrames(tuple(chunk), n_gt, n_pred, matched)


def _with_diagnosis(score: CulaneScore, diagnoses: FrameDiagnoses | None, categories: Mapping[str, frozenset[str]],
                    root: Path, width: int, diagnosis: DiagnosisSettings | None) -> CulaneScore:
    """The score with what --diagnose and --score-sweep write of it: frames grouped as
    official.csv groups them (category lists, then all), each frame's clip folder as its sequence;
    each frame's lanes read again (from `root` and the trees) for the gallery."""
    from ...metrics.lane_iou_f1 import category_groups

    if diagnosis is None or diagnoses is None:
        return score
    member_of = {frame: name for name, members in reversed(list(categories.items())) for frame in members}

    def facts(frame: str) -> tuple[str, str]:
        return frame.lstrip("/").rpartition("/")[0], member_of.get(frame, "")

    def lanes_of(frame: str) -> GalleryFrame:
        return GalleryFrame((IMAGE_WIDTH, IMAGE_HEIGHT), read_frame_labels(root, frame),
                            {tree.method: read_lines_txt(labels_path(tree.root, frame)) for tree in score.trees},
                            frame.lstrip("/"))

    groups = tuple(category_groups(diagnoses.frames, categories))
    return replace(score, diagnosed=Diagnosed(
        diagnoses, tuple((method, "") for method in score.methods), groups, score.thresholds.labels,
        diagnosis.loc_iou, facts,
        f"CULane, the lane IoU F1 of SCNN's evaluator ({width} px at {IMAGE_WIDTH}x{IMAGE_HEIGHT})",
        diagnosis.sweep, diagnosis.errors, frame_lanes=lanes_of, image_root=str(root)))


def _keep_truth(key: str | None, kept: list[TruthRuns] | None, say: Callable[[str], None]) -> None:
    """The ground truth drawn by this command, cached for the next ones (when it was not already)."""
    if key is not None and kept is not None:
        truth_cache.save(key, truth_cache.joined(kept), say)


def _joined(pieces: Iterable[ScoredFrames], n_methods: int) -> ScoredFrames:
    """The pieces as one, frames in order (a shard keeps every frame's numbers in its part)."""
    pieces = list(pieces)
    return ScoredFrames(
        tuple(frame for piece in pieces for frame in piece.frames),
        np.concatenate([p.n_gt for p in pieces]) if pieces else np.zeros(0, np.int64),
        np.concatenate([p.n_pred for p in pieces], axis=1) if pieces else np.zeros((n_methods, 0), np.int64),
        np.concatenate([p.matched_iou for p in pieces], axis=1) if pieces else np.zeros((n_methods, 0)),
    )


def _culane_score(pieces: Iterable[ScoredFrames], categories, thresholds: Thresholds, highlighted, trees,
                  n_frames: int, warnings, ground_truth: str, sweep: bool) -> CulaneScore:
    """The tables from the frames' results, each piece added up and let go as it comes: every
    method's numbers in memory at once are counts, not per-frame IoUs."""
    methods = [tree.method for tree in trees]
    counts = GroupCounts.zeros(len(methods), len(categories) + 1, thresholds.values)
    for piece in pieces:
        counts.add(piece, categories)
    official = counts.records(methods, list(categories), thresholds.labels)
    summary_columns, summary = summary_records(official, highlighted, thresholds.labels)
    return CulaneScore(PlainTable(OFFICIAL_COLUMNS, tuple(official)),
                       PlainTable(tuple(summary_columns), tuple(summary)),
                       thresholds, highlighted, tuple(trees), n_frames, tuple(warnings), ground_truth, sweep)


def write_culane_score(folder: OutputFolder, score: CulaneScore, width: int) -> None:
    """official.csv, summary.csv, summary.md; for a sweep of several checkpoints sweep.csv, sweep.json
    and sweep.png."""
    staging = Staging(folder)
    staging.write_text("official.csv", score.official_rows.to_csv())
    staging.write_text("summary.csv", score.summary_rows.to_csv())
    staging.write_text("summary.md", summary_markdown(score, width))
    if score.sweep and len(score.trees) > 1:
        from ...sweeps import plot_sweep

        table, best = culane_sweep(score)
        staging.write_text("sweep.csv", table.to_csv())
        staging.write_text("sweep.json", sweep_record("score culane", score.ground_truth, score.n_frames, width,
                                                      score.thresholds.labels, table.columns[2:-1], best))
        plot_sweep(table, staging.file("sweep.png"), f"CULane, all frames: {len(score.trees)} methods, "
                                                      f"IoU {grid_text(score.thresholds)}")
    write_diagnosis(staging, score.diagnosed, score.highlighted)
    folder.commit()


def sweep_record(command: str, ground_truth: str, n_frames: int, width: int, thresholds: Sequence[str],
                 columns: Sequence[str], best: str | None) -> str:
    """sweep.json: what a sweep was scored on and how, for `compare` to check sweeps against
    each other (their sweep.csv alone names no frames)."""
    import json

    from ...sweeps import SWEEP_FORMAT
    from ...version import __version__

    return json.dumps({"format": SWEEP_FORMAT, "command": command, "version": __version__, "frames": n_frames,
                       "ground_truth": ground_truth, "width": width, "thresholds": list(thresholds),
                       "columns": list(columns), "best": best}, indent=1) + "\n"


def culane_sweep(score: CulaneScore):
    """(sweep.csv's table, the best method): each method's headline F1s over all frames."""
    from ...sweeps import sweep_table

    columns = score.summary_rows.columns[2:]
    values = {row[0]: row[2:] for row in score.summary_rows.rows if row[1] == "all"}
    return sweep_table(score.methods, columns, values)


def _culane_ground_truth(relpaths: Sequence[str], categories: Mapping[str, frozenset[str]]) -> str:
    """What the parts of one command share: the list's frames in order and each category's frames
    among them (what merge checks the parts' frames against)."""
    from ...shards import digest

    listed = set(relpaths)
    return digest({"frames": list(relpaths),
                   "categories": [[name, sorted(members & listed)] for name, members in categories.items()]})


def _write_culane_part(folder: OutputFolder, share, scored: ScoredFrames, dataset, relpaths, trees, warnings,
                       iou, preset, width: int, strict: bool, sweep: bool, diagnosis: dict | None,
                       diagnosed: dict[str, np.ndarray]) -> None:
    from ...shards import PART_FORMAT, PART_VERSION, write_part
    from ...version import __version__

    from ...shards import digest, files_fingerprint, predictions_fingerprint

    listed = _culane_ground_truth(relpaths, dataset.categories)
    labels = files_fingerprint([labels_path(dataset.root, relpath) for relpath in relpaths])
    manifest = {
        "format": PART_FORMAT, "format_version": PART_VERSION, "command": "score culane", "version": __version__,
        "shard": [share.index, share.count],
        "settings": {"iou": None if iou is None else str(iou), "preset": preset, "width": width, "strict": strict,
                     "sweep": sweep,
                     "trees": [[t.method, os.path.abspath(t.root), t.found, t.listed] for t in trees],
                     "categories": list(dataset.categories), "frames": len(relpaths),
                     # --diagnose, --score-sweep: as given, and the data root the merge reads the gallery's lanes from
                     **({} if diagnosis is None else {"diagnosis": diagnosis})},
        # the list and categories (what merge checks the parts' frames against) and the label files
        # (path, size, modification time: what the parts must agree on)
        "ground_truth": digest({"list": listed, "labels": labels}), "list": listed,
        "warnings": list(warnings),
        "scored_frames": len(scored.frames),
        "predictions": predictions_fingerprint(trees, _files_of(trees), scored.frames),
    }
    arrays = {"frames": np.array(scored.frames, dtype=str) if scored.frames else np.zeros(0, "<U1"),
              "n_gt": scored.n_gt, "n_pred": scored.n_pred, "matched_iou": scored.matched_iou}
    for k, members in enumerate(dataset.categories.values()):
        arrays[f"category_{k}"] = np.array([frame in members for frame in scored.frames], bool)
    arrays.update(diagnosed)
    staging = Staging(folder)
    write_part(staging, manifest, arrays)
    folder.commit()


def _files_of(trees: Sequence[PredictionTree]) -> Callable[[int, str], tuple[Path]]:
    """A frame's prediction file in each tree (what a part fingerprints)."""
    return lambda m, relpath: (labels_path(trees[m].root, relpath),)


def _culane_part_settings(part) -> dict:
    """A `score culane` part's settings, each field's type checked (an untrusted file)."""
    from ...shards import MANIFEST_NAME

    settings, warnings = part.manifest["settings"], part.manifest.get("warnings")
    good = (isinstance(settings, dict) and _settings_named(settings) and _scoring_settings(settings)
            and _texts(settings["categories"]) and _count(settings["frames"]) and _texts(warnings)
            and _trees_recorded(settings["trees"], settings["frames"]))
    if not good:
        raise InputError(part.path / MANIFEST_NAME, "its settings are not those `score culane --shard` writes")
    return settings


def _texts(value) -> bool:
    return isinstance(value, list) and all(isinstance(v, str) for v in value)


def _count(value) -> bool:
    return type(value) is int and value >= 0


def _scoring_settings(settings: dict) -> bool:
    """--iou, --preset, --width, --strict and --sweep as `score culane` takes them."""
    from ...config import MAX_LINE_THICKNESS

    return ((settings["iou"] is None or isinstance(settings["iou"], str))
            and settings["preset"] in (None, *SCORE_PRESETS)
            and type(settings["width"]) is int and 2 <= settings["width"] <= MAX_LINE_THICKNESS
            and isinstance(settings["strict"], bool) and isinstance(settings["sweep"], bool))


def _trees_recorded(trees, frames: int) -> bool:
    """The prediction trees: [method, root, found, listed] each, methods distinct, every tree
    listing the part's frames (fewer than 2^31) and finding at most those."""
    if not isinstance(trees, list) or not all(
            isinstance(t, list) and len(t) == 4 and isinstance(t[0], str) and isinstance(t[1], str)
            and _count(t[2]) and _count(t[3]) for t in trees):
        return False
    methods = [t[0] for t in trees]
    return len(set(methods)) == len(methods) and frames < 1 << 31 and all(t[2] <= t[3] == frames for t in trees)


def _recorded_diagnosis(diagnosis: DiagnosisSettings | None, diagnose: bool, loc_iou: float | None,
                        score_sweep: str | None, root: Path) -> dict | None:
    """What a part records of --diagnose and --score-sweep: the options as given, and the data
    root the merge reads the gallery's lanes from (None without them)."""
    if diagnosis is None:
        return None
    return {"diagnose": diagnose, "loc_iou": loc_iou, "score_sweep": score_sweep, "data_root": os.path.abspath(root)}


def _settings_named(settings: dict) -> bool:
    """A part's settings have the names `score culane --shard` writes (its diagnosis if any)."""
    return (set(settings) - {"diagnosis"} == {"iou", "preset", "width", "strict", "sweep", "trees", "categories",
                                              "frames"} and _diagnosis_recorded(settings.get("diagnosis")))


def _diagnosis_recorded(value) -> bool:
    """A part's "diagnosis" setting: absent, or --diagnose, --loc-iou, --score-sweep and the data root."""
    return value is None or (
        isinstance(value, dict) and set(value) == {"diagnose", "loc_iou", "score_sweep", "data_root"}
        and isinstance(value["diagnose"], bool) and isinstance(value["data_root"], str)
        and (value["loc_iou"] is None or type(value["loc_iou"]) in (int, float))
        and (value["score_sweep"] is None or isinstance(value["score_sweep"], str)))


def _part_diagnoses(part, frames: list[str], diagnosis: DiagnosisSettings | None, n_methods: int
                    ) -> FrameDiagnoses | None:
    """A part's diagnoses from its arrays, each shape and range checked (an untrusted file)."""
    from ...shards import ARRAYS_NAME

    def checked(name: str, shape: tuple[int, ...], kind: str, within: tuple[int, int]) -> np.ndarray:
        array = part.arrays.get(name)
        if array is None or array.dtype.kind != kind or array.shape != shape or (
                array.size and not ((array >= within[0]) & (array <= within[1])).all()):
            raise InputError(part.path / ARRAYS_NAME, f"its {name} does not fit this score's methods and frames")
        return array

    try:
        return diagnoses_merged(diagnosis, frames, checked, n_methods)
    except ValueError as error:
        raise InputError(part.path / ARRAYS_NAME, str(error)) from None


def merge_culane_parts(parts, out: str | Path) -> CulaneScore:
    """The files one unsharded `score culane` writes, from its shards' parts (checked together)."""
    from ...shards import check_predictions
    from .parts import check_part_arrays

    first = parts[0].manifest
    settings = _culane_part_settings(parts[0])
    thresholds, highlighted = _thresholds(settings["iou"], settings["preset"])
    trees = tuple(PredictionTree(method, Path(root), found, listed)
                  for method, root, found, listed in settings["trees"])
    names = settings["categories"]
    recorded = settings.get("diagnosis")
    diagnosis = None if recorded is None else diagnosis_settings(
        recorded["diagnose"], recorded["loc_iou"], recorded["score_sweep"], thresholds.values)
    diagnosed: list[FrameDiagnoses] = []
    frames: list[str] = []
    n_gt, n_pred, matched = [], [], []
    members: list[list[str]] = [[] for _ in names]
    for part in parts:
        arrays = check_part_arrays(part, len(trees), len(names), diagnosis_part(diagnosis, None, len(trees)))
        part_frames = [str(v) for v in arrays["frames"].tolist()]
        diagnosed += [found for found in [_part_diagnoses(part, part_frames, diagnosis, len(trees))] if found]
        # a merge that does not find the trees where the parts say (merged elsewhere) cannot check them
        check_predictions(part.path, part.manifest.get("predictions"), trees, _files_of(trees), part_frames,
                          present_only=True)
        frames += part_frames
        n_gt.append(arrays["n_gt"])
        n_pred.append(arrays["n_pred"])
        matched.append(arrays["matched_iou"])
        for k in range(len(names)):
            members[k] += [f for f, inside in zip(part_frames, arrays[f"category_{k}"].tolist()) if inside]
    categories = {name: frozenset(found) for name, found in zip(names, members)}
    if _culane_ground_truth(frames, categories) != first.get("list"):
        raise InputError(parts[-1].path, f"the parts hold {len(frames):,} frames, not the {settings['frames']:,} "
                                         "frames of the list (and its categories) in order: not one command's shards")
    scored = ScoredFrames(tuple(frames), np.concatenate(n_gt), np.concatenate(n_pred, axis=1),
                          np.concatenate(matched, axis=1))
    score = _culane_score([scored], categories, thresholds, highlighted, trees, settings["frames"], first["warnings"],
                          first["list"], settings["sweep"])
    score = _with_diagnosis(score, joined_diagnoses(diagnosed), categories,
                            Path(recorded["data_root"]) if recorded else Path(), settings["width"], diagnosis)
    with _taking(out, "score culane") as folder:
        assert folder is not None
        write_culane_score(folder, score, settings["width"])
    return score


def grid_text(thresholds: Thresholds) -> str:
    """'0.50, 0.55, ..., 0.95 (10 thresholds)' or '0.5' for one."""
    labels = thresholds.labels
    if len(labels) == 1:
        return labels[0]
    shown = ", ".join(labels) if len(labels) <= 4 else f"{labels[0]}, {labels[1]}, ..., {labels[-1]}"
    return f"{shown} ({len(labels)} thresholds)"


def summary_table(score: CulaneScore) -> Table:
    """The summary as papers print it: F1 in percent, two decimals."""
    rows = tuple(tuple(str(v) if k < 2 else percent(float(v)) for k, v in enumerate(row))
                 for row in score.summary_rows.rows)
    return Table(score.summary_rows.columns, rows)


_RATIOS = {"precision": "precision (%)", "recall": "recall (%)", "f1": "F1 (%)"}


def first_threshold_table(score: CulaneScore) -> Table:
    """The counts, and precision, recall and F1 in percent as summary.md and papers print them,
    at the first threshold, as the console shows them."""
    first = score.first_rows
    columns = tuple(_RATIOS.get(column, column) for column in first.columns)
    rows = tuple(tuple(percent(v) if column in _RATIOS else str(v) for column, v in zip(first.columns, row))
                 for row in first.rows)
    return Table(columns, rows)


def summary_markdown(score: CulaneScore, width: int) -> str:
    """summary.md: what was measured, then F1@50, F1@75 and mF1 per method and category."""
    lines = [
        "# CULane, official protocol",
        "",
        f"SCNN tools/lane_evaluation: lanes drawn {width} px wide at 1640x590, one-to-one matching, a true "
        f"positive when IoU > threshold. {score.n_frames:,} frames; IoU {grid_text(score.thresholds)}.",
    ]
    if len(score.thresholds) > 1:
        lines.append("mF1 is the mean F1 over those thresholds (CLRNet's mF1 is the grid 0.50:0.95:0.05).")
    lines += ["F1 in percent. Every count is in official.csv (one row per method, category and threshold).", ""]
    for tree in score.trees:
        lines.append(f"- `{tree.method}`: {tree.root} ({tree.found:,} of {tree.listed:,} frames have a file)")
    lines += ["", summary_table(score).to_markdown()]
    return "\n".join(lines)


__all__ = ["score_culane", "CulaneScore", "SCORE_PRESETS", "highlight_name"]


def diagnose_run(lanes: Path, dataset, frames: Iterable[str], config, loc_iou: float | None,
                 announce: Callable[[str], None] | None = None) -> Diagnosed:
    """`run --diagnose`: the lanes the run saved (`lanes`) scored as `score culane --diagnose`
    scores them, at the run's threshold and lane width, over the frames it scored (`frames`)."""
    score = score_culane(dataset.root, lanes, dataset.source_file, iou=config.official.iou_threshold,
                         width=config.official.lane_width_px, workers=config.workers, announce=announce,
                         diagnose=True, loc_iou=loc_iou, frames=list(frames))
    assert score is not None and score.diagnosed is not None
    return score.diagnosed
