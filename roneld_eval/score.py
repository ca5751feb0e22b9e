"""Scoring lane files in the official formats: `score culane` and `score tusimple`.

CULane: every prediction tree (one method each) is scored in one pass over the ground truth:
each frame's labels are read and drawn once, then matched against every method's lanes. The
matched IoUs are kept, so a whole threshold grid (CLRNet's mF1: 0.50..0.95) costs no second
pass. Prediction roots are checked before any work: a root where no file of the list is
stops with the path looked for and the folder that would match. TuSimple: Acc/FP/FN as
evaluate/lane.py, with the two F1 formulas papers print. Writes nothing but `out`.

Start-up matters here (one frame should score in well under a second): the tables are plain
tuples written with the csv module, byte for byte what pandas' to_csv wrote, and pandas is
imported only when a DataFrame is asked for (CulaneScore.official, .summary, .table).
"""

from __future__ import annotations

import contextlib
import csv
import io
import math
import os
import posixpath
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING, Callable, Iterator, Union

import numpy as np

from .config import check_lane_width

from .thresholds import Thresholds, parse_thresholds
from .datasets.culane import read_culane
from .datasets._paths import under_root
from .datasets.culane import labels_path, read_frame_labels
from .errors import ConfigError, InputError
from .lanes_io import check_coordinates, read_culane_lines
from .metrics.culane_official import (
    OFFICIAL_COLUMNS,
    GroupCounts,
    ScoredFrames,
    frame_result,
    highlight_name,
    official_masks,
    summary_records,
)
from .model import image_stem
from .output import OutputFolder
from .report.tables import Table
from .output import Staging
from .shards import Merged, Sharding
from .signals import terminate_as_interrupt
from . import truth_cache
from .truth_cache import TruthRuns

if TYPE_CHECKING:
    import pandas as pd

    from .metrics.raster import MaskSet

    from .metrics.tusimple_official import TusimpleScore


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
# The thresholds papers single out, shown whenever the grid holds them.
HIGHLIGHTS = ("0.50", "0.75")
CHUNK_FRAMES = 200

# a path or 'NAME=DIR'; several, or (name, folder) pairs among them; or a mapping of name to folder
PredictionRoots = Union[str, Path, Sequence[Union[str, Path, tuple]], Mapping[str, Union[str, Path]]]


@dataclass(frozen=True)
class PredictionTree:
    """One method's `.lines.txt` tree and how many of the listed frames have a file in it."""

    method: str
    root: Path
    found: int
    listed: int


@dataclass(frozen=True)
class PlainTable:
    """A table as plain Python values (str, int, float; NaN where undefined): what a CSV file holds."""

    columns: tuple[str, ...]
    rows: tuple[tuple, ...]

    def to_csv(self) -> str:
        """The text pandas' `to_csv(index=False, float_format="%.6f", lineterminator="\n")` writes
        for this table, byte for byte: floats with 6 decimals, NaN empty, csv's minimal quoting."""
        text = io.StringIO()
        # The dialect pandas hands csv.writer (pandas.io.formats.csvs), so that quoting is the same.
        writer = csv.writer(text, lineterminator="\n", delimiter=",", quoting=csv.QUOTE_MINIMAL, doublequote=True,
                            escapechar=None, quotechar='"')
        writer.writerow(self.columns)
        writer.writerows(tuple(_csv_cell(value) for value in row) for row in self.rows)
        return text.getvalue()

    def to_frame(self) -> pd.DataFrame:
        import pandas as pd

        return pd.DataFrame(list(self.rows), columns=list(self.columns))


def _csv_cell(value) -> object:
    # Every float column holds only floats (a NaN keeps it float), so formatting by value is by column.
    if isinstance(value, float):
        return "" if math.isnan(value) else "%.6f" % value
    return value


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


# ---- finding the prediction trees ------------------------------------------------------------


class _ListedFiles:
    """The `.lines.txt` names the list asks for, grouped by folder, to count them under any root
    with one directory listing per folder (34,680 frames: 419 listings, not 34,680 stats)."""

    def __init__(self, relpaths: Sequence[str], suffix: str = ".lines.txt"):
        self.relpaths = relpaths
        self.suffix = suffix
        self.by_folder: dict[str, list[str]] = {}
        for relpath in relpaths:
            label = f"{image_stem(relpath)}{suffix}"
            # The name as the disk spells it, as under_root spells paths (UTF-8 whatever the locale).
            name = os.fsdecode(posixpath.basename(label).encode("utf-8", "surrogateescape"))
            self.by_folder.setdefault(posixpath.dirname(label), []).append(name)

    def count(self, root: Path) -> int:
        found = 0
        for folder, names in self.by_folder.items():
            try:
                present = set(os.listdir(under_root(root, folder) if folder else root))
            except (FileNotFoundError, NotADirectoryError):
                continue
            except OSError:
                found += len(names)  # there but unreadable: reading the files names the problem
                continue
            found += sum(name in present for name in names)
        return found

    def first_missing(self, root: Path) -> Path:
        for relpath in self.relpaths:
            path = self.path(root, relpath)
            if not path.exists():
                return path
        return self.path(root, self.relpaths[0])

    def path(self, root: Path, relpath: str) -> Path:
        return under_root(root, f"{image_stem(relpath)}{self.suffix}")


def _subfolders(root: Path) -> list[Path]:
    try:
        return sorted((Path(entry.path) for entry in os.scandir(root)
                       if entry.is_dir() and not entry.name.startswith(".")), key=lambda p: p.name)
    except OSError:
        return []


def _root_specs(pred_root: PredictionRoots) -> list[tuple[str | None, Path]]:
    """(name or None, folder) of each root given: a path, 'NAME=DIR', a list of them, or a mapping."""
    if isinstance(pred_root, Mapping):
        return [(str(name), Path(path)) for name, path in pred_root.items()]
    if isinstance(pred_root, (str, Path)):
        pred_root = [pred_root]
    specs: list[tuple[str | None, Path]] = []
    for item in pred_root:
        if isinstance(item, (tuple, list)):  # (name, folder): a glob's match, or a part's record
            if (len(item) != 2 or not isinstance(item[1], (str, Path))
                    or not (item[0] is None or isinstance(item[0], str))):
                raise ConfigError(f"a prediction root given as a pair must be (name, folder), got {item!r}")
            specs.append((item[0] or None, Path(item[1])))
            continue
        text = str(item)
        name, sep, folder = text.partition("=")
        # NAME=DIR, unless the whole text is itself an existing folder (a path may hold '=').
        if isinstance(item, str) and sep and name and "/" not in name and folder and not Path(text).exists():
            specs.append((name, Path(folder)))
        else:
            specs.append((None, Path(item)))
    if not specs:
        raise ConfigError("give at least one prediction root")
    return specs


def _no_match(root: Path, listed: _ListedFiles, option: str = "--pred-root") -> InputError:
    """The one-line error for a root without any file of the list, with the folder that has them."""
    first = listed.path(root, listed.relpaths[0])
    hint = ""
    parent = root.parent if len(root.parts) > 1 else root.resolve().parent  # as the user wrote it, if possible
    if parent.resolve() != root.resolve() and listed.count(parent):
        hint = f"; did you mean {option} {parent} (it holds them)?"
    else:
        for child in _subfolders(root):
            methods = [grandchild.name for grandchild in _subfolders(child) if listed.count(grandchild)]
            if methods:
                hint = (f"; did you mean {option} {child} (its subfolders {', '.join(methods[:4])}"
                        f"{', ...' if len(methods) > 4 else ''} each hold them)?")
                break
    return InputError(root, f"no prediction file of the list is here (first looked for: {first}){hint}")


def find_prediction_trees(pred_root: PredictionRoots, relpaths: Sequence[str], strict: bool = False,
                          announce: Callable[[str], None] | None = None,
                          suffix: str = ".lines.txt", option: str = "--pred-root"
                          ) -> tuple[list[PredictionTree], list[str]]:
    """The methods to score and warnings about them, checked before any work.

    A root that mirrors the list is one method (named by its folder, or NAME=DIR); otherwise
    each of its subfolders that does is one (as `run --save-lanes` writes OUT/lanes/<method>/).
    A root with no file of the list at all is an error naming the path looked for and the
    folder that has them (one level up, or a folder of methods one level down). Fewer than
    half the listed files is a warning; with `strict`, any missing file is an error.
    """
    say = announce or (lambda message: None)
    listed = _ListedFiles(relpaths, suffix)
    trees: list[PredictionTree] = []
    for name, root in _root_specs(pred_root):
        if not root.is_dir():
            raise InputError(root, "prediction root not found")
        found = listed.count(root)
        if found:
            # named as given (a link to a checkpoint keeps its own name), "." and ".." made absolute first
            trees.append(PredictionTree(name or Path(os.path.abspath(root)).name, root, found, len(relpaths)))
            continue
        children, others = [], []
        for child in _subfolders(root):
            count = listed.count(child)
            if count:
                children.append(PredictionTree(f"{name}/{child.name}" if name else child.name, child, count,
                                               len(relpaths)))
            else:
                others.append(child)
        if not children:
            raise _no_match(root, listed, option)
        for child in others:
            say(f"{child}: not a prediction tree (no file of the list), left out")
        trees += children
    seen: dict[str, Path] = {}
    for tree in trees:
        try:
            tree.method.encode("utf-8")
        except UnicodeEncodeError:  # the method's name goes into every table
            raise InputError(tree.root, "the folder's name is not valid Unicode text (not UTF-8): rename it, "
                                        "or name the method with --pred-root NAME=DIR") from None
        if tree.method in seen:
            raise ConfigError(f"two prediction trees are named {tree.method!r} ({seen[tree.method]} and {tree.root}): "
                              f"name them with {option} NAME=DIR")
        seen[tree.method] = tree.root
    warnings = []
    for tree in trees:
        missing = tree.listed - tree.found
        if strict and missing:
            raise InputError(tree.root, f"{missing:,} of {tree.listed:,} listed frames have no prediction file "
                                        f"(first: {listed.first_missing(tree.root)}); --strict needs every one")
        if tree.found * 2 < tree.listed:
            warnings.append(f"warning: {tree.root}: only {tree.found:,} of {tree.listed:,} listed frames have a "
                            f"prediction file; the other {missing:,} count as frames without lanes")
    return trees, warnings


# ---- scoring lane files ----------------------------------------------------------------------


def _score_frames(args) -> tuple[np.ndarray, np.ndarray, np.ndarray, TruthRuns | None]:
    """One chunk of frames against every method: (n_gt, n_pred per method, matched IoUs per
    method, and the ground truth as drawn when `keep_truth`). `truth`: (a checked entry of the
    ground-truth cache, the chunk's first frame in it) to take the frames' drawn lanes from."""
    relpaths, data_root, pred_roots, width, height, lane_width, truth, keep_truth = args
    cached = None if truth is None else truth_cache.open_entry(truth[0])
    n_gt = np.zeros(len(relpaths), np.int64)
    n_pred = np.zeros((len(pred_roots), len(relpaths)), np.int64)
    ious: list[list[np.ndarray]] = [[] for _ in pred_roots]
    drawn: list[tuple[int, MaskSet | None]] = []
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
            predictions = read_culane_lines(path)
            check_coordinates(predictions, path)
            result = frame_result(int(n_gt[k]), gt_masks, predictions, width, height, lane_width)
            n_pred[m, k] = result.n_pred
            ious[m].append(result.matched_iou)
    matched = np.array([np.concatenate(parts) if parts else np.zeros(0) for parts in ious], np.float64)
    kept = truth_cache.from_frames(drawn) if keep_truth and cached is None else None
    return n_gt, n_pred, matched.reshape(len(pred_roots), int(n_gt.sum())), kept


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
    highlighted = tuple(label for label in thresholds.labels if label in HIGHLIGHTS)
    return thresholds, highlighted or thresholds.labels[:1]


def scored_pieces(function: Callable, tasks: Sequence[tuple], workers: int | None, progress: bool,
                  announce: Callable[[str], None] | None = None, kernel_groups: tuple[str, ...] = ("official",),
                  unit: str = "frame") -> list:
    """`function` over tasks whose first item is their frames, in order: in worker processes for
    more than one task (all cores unless `workers`), else here; a progress bar counts frames.
    The kernels are compiled once here first, not in every worker."""
    from tqdm import tqdm

    from . import kernels

    if kernel_groups:
        kernels.prepare(announce=announce, needed=kernel_groups)
    from .workers import worker_count

    pieces = []
    with tqdm(total=sum(len(task[0]) for task in tasks), unit=unit, desc="scoring", disable=not progress) as bar:
        if len(tasks) > 1 and worker_count(workers) != 1:
            from .workers import process_pool, stopping

            died = "a worker process died (killed, or out of memory) while scoring: no result was written"
            with stopping(process_pool(min(worker_count(workers), len(tasks))), lambda: died) as pool:
                for task, piece in zip(tasks, pool.map(function, tasks)):
                    pieces.append(piece)
                    bar.update(len(task[0]))
        else:
            if kernel_groups:
                kernels.warm_up(kernel_groups)  # loaded here in one go, not frame by frame
            for task in tasks:
                pieces.append(function(task))
                bar.update(len(task[0]))
    return pieces


@contextlib.contextmanager
def _taking(out: str | Path | None, command: str) -> Iterator[OutputFolder | None]:
    """The whole command with SIGTERM and SIGHUP ending it as Ctrl-C does, and OUT (when given)
    checked and locked before any work, not refused after it."""
    with terminate_as_interrupt():
        if out is None:
            yield None
            return
        with OutputFolder(out, command) as folder:
            yield folder


def score_culane(data_root: str | Path, pred_root: PredictionRoots, list_file: str | Path | None = None,
                 iou: str | float | None = None, width: int = 30, out: str | Path | None = None,
                 workers: int | None = None, progress: bool = False,
                 announce: Callable[[str], None] | None = None, preset: str | None = None,
                 strict: bool = False, shard: str | None = None) -> CulaneScore | None:
    """Score `.lines.txt` predictions with the official CULane protocol, every method in one pass.

    `pred_root`: a folder mirroring the list, a folder of such folders (one per method), or
    several ('NAME=DIR' names one). `iou`: one threshold (default 0.5) or a grid scored in
    one pass ('0.50:0.95:0.05'); `preset='clrnet'` is that grid with F1@50/F1@75/mF1.
    A missing prediction file means no lanes (`strict`: an error). `out` gets official.csv,
    summary.csv and summary.md; with `shard` ('I/N', see roneld_eval.shards) only that share
    of the clips is scored and `out` gets its part for `merge` (None is returned).
    """
    from .shards import parse_shard, shard_range

    from .sweeps import expand_roots

    thresholds, highlighted = _thresholds(iou, preset)
    check_lane_width(width)
    share = parse_shard(shard) if shard is not None else None
    if not isinstance(pred_root, Mapping):  # glob patterns: one method per folder matched
        pred_root = expand_roots([pred_root] if isinstance(pred_root, (str, Path)) else list(pred_root))
    if share is not None and out is None:
        raise ConfigError("--shard writes a partial result for `roneld-eval merge`: give --out")
    with _taking(out, "score culane") as folder:
        dataset = read_culane(data_root, list_file, labels=False, require_labels=True)
        relpaths = [frame.relpath for clip in dataset.clips for frame in clip.frames]
        # every shard finds the methods over the whole list: the same trees (and counts) in every part
        trees, warnings = find_prediction_trees(pred_root, relpaths, strict, announce)
        if share is not None:
            cut = shard_range([len(c.frames) for c in dataset.clips], share)
            clips = dataset.clips[cut.start:cut.stop]
            scored_relpaths = [frame.relpath for clip in clips for frame in clip.frames]
        else:
            scored_relpaths = relpaths
        say = announce or (lambda message: None)
        key = truth_cache.truth_key(dataset.root, scored_relpaths, dataset.image_width, dataset.image_height,
                                    width, labels_path) if truth_cache.enabled() else None
        truth = None if key is None else truth_cache.load(key, len(scored_relpaths), dataset.image_width,
                                                           dataset.image_height, say)
        kept: list[TruthRuns] | None = [] if key is not None and truth is None else None
        pieces = _culane_pieces(scored_relpaths, dataset, trees, width, workers, progress, announce, truth, kept)
        if share is not None:
            assert folder is not None
            joined = _joined(pieces, len(trees))
            _keep_truth(key, kept, say)
            _write_culane_part(folder, share, joined, dataset, relpaths, trees, warnings, iou, preset, width, strict)
            return None
        score = _culane_score(pieces, dataset.categories, thresholds, highlighted, trees, len(relpaths), warnings,
                              _culane_ground_truth(relpaths, dataset.categories))
        _keep_truth(key, kept, say)
        if folder is not None:
            write_culane_score(folder, score, width)
    return score


def _culane_pieces(relpaths: list[str], dataset, trees, width: int, workers: int | None, progress: bool,
                   announce, truth: Path | None = None, kept: list[TruthRuns] | None = None) -> Iterator[ScoredFrames]:
    """Every method's frame results on these frames, chunk after chunk, in their order. `truth`:
    a checked entry of the ground-truth cache holding these frames; else, with `kept` given, the
    ground truth as drawn is appended to it chunk by chunk."""
    image_width, image_height = dataset.image_width, dataset.image_height
    roots = tuple(tree.root for tree in trees)
    chunks = [relpaths[i:i + CHUNK_FRAMES] for i in range(0, len(relpaths), CHUNK_FRAMES)]
    tasks = [(chunk, dataset.root, roots, image_width, image_height, width,
              None if truth is None else (str(truth), i * CHUNK_FRAMES), kept is not None)
             for i, chunk in enumerate(chunks)]
    if len(chunks) > 1:  # a pool only for more than one chunk: a small set starts without multiprocessing
        from .workers import worker_count

        workers = min(worker_count(workers), len(chunks))
    else:
        workers = 1
    from . import kernels

    kernels.prepare(announce=announce, needed=("official",))  # once here, not in every worker
    if workers == 1:
        kernels.warm_up(("official",))  # loaded here in one go (start-up: see kernels.warm_up), not frame by frame
    from tqdm import tqdm

    with tqdm(total=len(relpaths), unit="frame", desc="scoring", disable=not progress) as bar:
        if workers > 1:
            from .workers import process_pool, stopping

            died = "a worker process died (killed, or out of memory) while scoring: no result was written"
            with stopping(process_pool(workers), lambda: died) as pool:
                for chunk, piece in zip(chunks, pool.map(_score_frames, tasks)):
                    bar.update(len(chunk))
                    yield _piece(chunk, piece, kept)
        else:
            for chunk, task in zip(chunks, tasks):
                piece = _score_frames(task)
                bar.update(len(chunk))
                yield _piece(chunk, piece, kept)


def _piece(chunk: list[str], piece: tuple, kept: list[TruthRuns] | None) -> ScoredFrames:
    n_gt, n_pred, matched, truth = piece
    if kept is not None and truth is not None:
        kept.append(truth)
    return ScoredFrames(tuple(chunk), n_gt, n_pred, matched)


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
                  n_frames: int, warnings, ground_truth: str) -> CulaneScore:
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
                       thresholds, highlighted, tuple(trees), n_frames, tuple(warnings), ground_truth)


def write_culane_score(folder: OutputFolder, score: CulaneScore, width: int) -> None:
    """official.csv, summary.csv, summary.md; with several methods sweep.csv, sweep.json and sweep.png."""
    staging = Staging(folder)
    staging.write_text("official.csv", score.official_rows.to_csv())
    staging.write_text("summary.csv", score.summary_rows.to_csv())
    staging.write_text("summary.md", summary_markdown(score, width))
    if len(score.trees) > 1:
        from .sweeps import plot_sweep

        table, best = culane_sweep(score)
        staging.write_text("sweep.csv", table.to_csv())
        staging.write_text("sweep.json", sweep_record("score culane", score.ground_truth, score.n_frames, width,
                                                      score.thresholds.labels, table.columns[2:-1], best))
        plot_sweep(table, staging.file("sweep.png"), f"CULane, all frames: {len(score.trees)} methods, "
                                                      f"IoU {grid_text(score.thresholds)}")
    folder.commit()


def sweep_record(command: str, ground_truth: str, n_frames: int, width: int, thresholds: Sequence[str],
                 columns: Sequence[str], best: str | None) -> str:
    """sweep.json: what a sweep was scored on and how, for `compare` to check sweeps against
    each other (their sweep.csv alone names no frames)."""
    import json

    from .sweeps import SWEEP_FORMAT
    from .version import __version__

    return json.dumps({"format": SWEEP_FORMAT, "command": command, "version": __version__, "frames": n_frames,
                       "ground_truth": ground_truth, "width": width, "thresholds": list(thresholds),
                       "columns": list(columns), "best": best}, indent=1) + "\n"


def culane_sweep(score: CulaneScore):
    """(sweep.csv's table, the best method): each method's headline F1s over all frames."""
    from .sweeps import sweep_table

    columns = score.summary_rows.columns[2:]
    values = {row[0]: row[2:] for row in score.summary_rows.rows if row[1] == "all"}
    return sweep_table(score.methods, columns, values)


def _culane_ground_truth(relpaths: Sequence[str], categories: Mapping[str, frozenset[str]]) -> str:
    """What the parts of one command share: the list's frames in order and each category's frames
    among them (what merge checks the parts' frames against)."""
    from .shards import digest

    listed = set(relpaths)
    return digest({"frames": list(relpaths),
                   "categories": [[name, sorted(members & listed)] for name, members in categories.items()]})


def _write_culane_part(folder: OutputFolder, share, scored: ScoredFrames, dataset, relpaths, trees, warnings,
                       iou, preset, width: int, strict: bool) -> None:
    from .shards import PART_FORMAT, PART_VERSION, write_part
    from .version import __version__

    from .shards import digest, files_fingerprint

    listed = _culane_ground_truth(relpaths, dataset.categories)
    labels = files_fingerprint([labels_path(dataset.root, relpath) for relpath in relpaths])
    manifest = {
        "format": PART_FORMAT, "format_version": PART_VERSION, "command": "score culane", "version": __version__,
        "shard": [share.index, share.count],
        "settings": {"iou": None if iou is None else str(iou), "preset": preset, "width": width, "strict": strict,
                     "trees": [[t.method, os.path.abspath(t.root), t.found, t.listed] for t in trees],
                     "categories": list(dataset.categories), "frames": len(relpaths)},
        # the list and categories (what merge checks the parts' frames against) and the label files
        # (path, size, modification time: what the parts must agree on)
        "ground_truth": digest({"list": listed, "labels": labels}), "list": listed,
        "warnings": list(warnings),
        "scored_frames": len(scored.frames),
    }
    arrays = {"frames": np.array(scored.frames, dtype=str) if scored.frames else np.zeros(0, "<U1"),
              "n_gt": scored.n_gt, "n_pred": scored.n_pred, "matched_iou": scored.matched_iou}
    for k, members in enumerate(dataset.categories.values()):
        arrays[f"category_{k}"] = np.array([frame in members for frame in scored.frames], bool)
    staging = Staging(folder)
    write_part(staging, manifest, arrays)
    folder.commit()


def _culane_part_settings(part) -> dict:
    """A `score culane` part's settings, each field's type checked (an untrusted file)."""
    from .config import MAX_LINE_THICKNESS
    from .shards import MANIFEST_NAME

    settings, warnings = part.manifest["settings"], part.manifest.get("warnings")

    def texts(value) -> bool:
        return isinstance(value, list) and all(isinstance(v, str) for v in value)

    def count(value) -> bool:
        return type(value) is int and value >= 0

    good = (isinstance(settings, dict)
            and set(settings) == {"iou", "preset", "width", "strict", "trees", "categories", "frames"}
            and (settings["iou"] is None or isinstance(settings["iou"], str))
            and settings["preset"] in (None, *SCORE_PRESETS)
            and type(settings["width"]) is int and 2 <= settings["width"] <= MAX_LINE_THICKNESS
            and isinstance(settings["strict"], bool) and texts(settings["categories"]) and count(settings["frames"])
            and isinstance(settings["trees"], list) and texts(warnings)
            and all(isinstance(t, list) and len(t) == 4 and isinstance(t[0], str) and isinstance(t[1], str)
                    and count(t[2]) and count(t[3]) for t in settings["trees"]))
    if good:
        methods = [t[0] for t in settings["trees"]]
        good = (len(set(methods)) == len(methods) and settings["frames"] < 1 << 31
                and all(t[2] <= t[3] == settings["frames"] for t in settings["trees"]))
    if not good:
        raise InputError(part.path / MANIFEST_NAME, "its settings are not those `score culane --shard` writes")
    return settings


def merge_culane_parts(parts, out: str | Path) -> CulaneScore:
    """The files one unsharded `score culane` writes, from its shards' parts (checked together)."""
    from .shards import check_part_arrays

    first = parts[0].manifest
    settings = _culane_part_settings(parts[0])
    thresholds, highlighted = _thresholds(settings["iou"], settings["preset"])
    trees = tuple(PredictionTree(method, Path(root), found, listed)
                  for method, root, found, listed in settings["trees"])
    names = settings["categories"]
    frames: list[str] = []
    n_gt, n_pred, matched = [], [], []
    members: list[list[str]] = [[] for _ in names]
    for part in parts:
        arrays = check_part_arrays(part, len(trees), len(names))
        part_frames = [str(v) for v in arrays["frames"].tolist()]
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
                          first["list"])
    with _taking(out, "score culane") as folder:
        assert folder is not None
        write_culane_score(folder, score, settings["width"])
    return score


def percent(value: float) -> str:
    """A fraction as the summary tables print it: percent with 2 decimals, n/a for NaN."""
    return "n/a" if np.isnan(value) else f"{100 * value:.2f}"


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


def score_tusimple(labels: str | Path, pred: str | Path, out: str | Path | None = None, shard: str | None = None,
                   merged: Merged | None = None) -> TusimpleScore | None:
    """Score TuSimple JSON-lines predictions against a label file, as evaluate/lane.py does,
    with F1 under UFLD-v2's and CLRNet's formulas (f1_ufld, f1_clrnet). With `shard` ('I/N'),
    only that share of the clips (in label-file order), written as a part to `out` (None is
    returned); the part keeps each frame's scores and their lines, which a merge adds up in the
    prediction file's order, as lane.py does."""
    from .metrics.tusimple_official import frame_scores, mean_scores, read_labels

    sharding = Sharding("score tusimple", shard, out, merged, dict(labels=labels, pred=pred),
                        paths=("labels", "pred"))
    with _taking(out, "score tusimple") as folder:
        gts = read_labels(labels)
        keys, files = list(gts), [Path(labels), Path(pred)]
        if merged is not None:
            sharding.check_merged(keys, [], files, posixpath.dirname)
            lines, _ = frame_scores(labels, pred, gts, checked_only=True)  # every line checked, none scored
            taken = sharding.merged_array("cat_line", (len(gts),), "i")
            # FP is below 0 where several labelled lanes match one prediction
            values = sharding.merged_array("cat_scores", (len(gts), 3), "f", within=(-1e6, 1e6))
            order = np.argsort(taken, kind="stable")
            if not np.array_equal(taken[order], np.array(lines, np.int64)):
                raise InputError(None, "the parts' frames are not the prediction file's lines: not its shards")
            scores = [(float(a), float(p), float(n)) for a, p, n in values[order].tolist()]
        else:
            share = sharding.share(keys, posixpath.dirname)  # a clip: a folder of frames
            lines, scores = frame_scores(labels, pred, gts, None if sharding.shard is None else frozenset(share))
            if sharding.shard is not None:
                assert folder is not None
                sharding.write_part(folder, keys, [], files, share,
                                    {"cat_line": np.array(lines, np.int64),
                                     "cat_scores": np.array(scores, np.float64).reshape(-1, 3)})
                return None
        score = mean_scores(scores, len(gts))
        if folder is not None:
            import pandas as pd

            table = pd.DataFrame([score.as_row()])
            Staging(folder).write_text("official.csv", table.to_csv(index=False, float_format="%.10g",
                                                                    lineterminator="\n"))
            folder.commit()
    return score


__all__ = ["score_culane", "score_tusimple", "CulaneScore", "PlainTable", "PredictionTree", "find_prediction_trees",
           "SCORE_PRESETS", "highlight_name"]
