"""`score openlane3d`: 3-D lane results scored as OpenLane's lane3d evaluator scores them
(OpenDriveLab/OpenLane 8a0ce6b, eval/LANE_evaluation/lane3d: `bench_one_submit`, the file-based
protocol PersFormer's copy shares at its HEAD): F, recall, precision, category accuracy and the x/z
errors near (0-40 m) and far (40-100 m), from every frame's counts (official.py), over the list
and over each scenario list given.

official.csv has a row per method and scenario (`all` first): the six sums bench_one_submit adds
(recalled, precise, right category, ground-truth lanes, predicted lanes, matches) and the eight
numbers it prints. The evaluator prints them with `{:.8}`; summary.md does the same.
"""

from __future__ import annotations

import posixpath
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Sequence

import numpy as np

from ...errors import ConfigError, InputError
from ...scoring import (PlainTable, PredictionRoots, _taking, find_prediction_trees, scored_pieces, stopping_gaps,
                        write_texts)
from ...shards import Merged, Sharding
from ...metrics import lane3d_flow
from .official import frame_counts, ground_truth_lanes, totals
from .reader import json_path, read_list, read_prediction, read_truth

# bench_one_submit: every lane of the result files; bench_one_submit_openlane_DDP: PersFormer's training-time
# evaluation, lanes with class probabilities, kept above a threshold, their category the most probable
PROTOCOLS = ("file", "persformer-train")
PROB_THRESHOLD = 0.5  # bench_one_submit_openlane_DDP(prob_th=0.5)
SUMS = ("recalled", "precise", "category_right", "gt_lanes", "pred_lanes", "matches")
PRINTED = ("f", "recall", "precision", "category_accuracy", "x_error_near", "x_error_far", "z_error_near",
           "z_error_far")
COLUMNS = ("method", "scenario", "frames", *SUMS, *PRINTED)
CHUNK_FRAMES = 200


@dataclass(frozen=True)
class OpenLane3dScore:
    rows: PlainTable
    methods: tuple[str, ...]
    scenarios: tuple[str, ...]
    n_frames: int
    warnings: tuple[str, ...] = ()
    protocol: str = "file"
    prob_threshold: float | None = None  # persformer-train: a lane kept above it

    def describe(self) -> str:
        """The protocol as the tables name it."""
        if self.protocol == "file":
            return "protocol 'file': every lane of each result file, as bench_one_submit reads it"
        return (f"protocol 'persformer-train': PersFormer's training-time evaluation (bench_one_submit_openlane_DDP), "
                f"a lane kept when its highest class probability is above {self.prob_threshold:g}, its category "
                "the most probable")

    def value(self, method: str, column: str, scenario: str = "all") -> float:
        at = COLUMNS.index(column)
        return next(row[at] for row in self.rows.rows if row[0] == method and row[1] == scenario)


def _score_frames(args) -> tuple[np.ndarray, list[np.ndarray], list[str]]:
    """(frames, methods, 6) counts of one chunk, per method its matches' errors (matches, 4), and
    each label's file_path (which a merge of chunks checks once over the list)."""
    relpaths, labels, roots, prob_threshold = args
    stats = np.zeros((len(relpaths), len(roots), 6))
    errors: list[list[np.ndarray]] = [[] for _ in roots]
    keys = []
    for f, relpath in enumerate(relpaths):
        label = json_path(labels, relpath)
        truth = read_truth(label)
        keys.append(truth.key)
        gt_lanes = ground_truth_lanes(truth.extrinsic, truth.lanes)
        for m, root in enumerate(roots):
            path = json_path(root, relpath)
            predicted = read_prediction(path, prob_threshold)
            if predicted.key is not None and predicted.key != truth.key:
                raise InputError(path, f"its file_path {predicted.key!r} is not its label's ({truth.key!r} in "
                                       f"{label}): the evaluator pairs them by it")
            try:
                counts = frame_counts(list(predicted.lanes), list(predicted.categories), gt_lanes,
                                      list(truth.visibility), list(truth.categories))
            except ValueError as error:  # a distance beyond the integer cost
                raise InputError(path, f"{error} (with its label {label})") from None
            stats[f, m] = counts.counts()
            errors[m].append(counts.errors)
    return stats, [np.concatenate(found) if found else np.zeros((0, 4)) for found in errors], keys


def _once_each(keys: Sequence[str], relpaths: Sequence[str], labels: Path) -> None:
    """Each label's file_path once: the evaluator keeps the last label of a file_path and pairs every
    result of that path with it, which would score another frame twice and this one never."""
    first: dict[str, str] = {}
    for key, relpath in zip(keys, relpaths):
        if key in first:
            raise InputError(json_path(labels, relpath), f"its file_path {key!r} is also that of "
                                                         f"{json_path(labels, first[key])}: each label needs its own")
        first[key] = relpath


def _scenarios(folder: str | Path | None, relpaths: Sequence[str]) -> dict[str, np.ndarray]:
    """Scenario name -> mask over the scored frames: `all`, then each scenario in `folder`, as a
    folder of its annotations (lane3d_1000/test/<case>/<segment>/<frame>.json, as PersFormer points
    at them) or a `<case>.txt` list of images."""
    found = {"all": np.ones(len(relpaths), bool)}
    if folder is None:
        return found
    folder = Path(folder)
    if not folder.is_dir():
        raise InputError(folder, "scenario folder not found (expected a folder of annotations, or a <case>.txt "
                                 "image list, for each case)")
    index = {relpath: k for k, relpath in enumerate(relpaths)}
    cases = sorted([path for path in folder.iterdir() if path.is_dir() or path.suffix == ".txt"],
                   key=lambda path: path.stem)
    for path in cases:
        if path.stem in found:
            raise InputError(path, "a scenario of this name is given twice (a folder and a list, or 'all')")
        found[path.stem] = _scenario(path, index)
    if len(found) == 1:
        raise InputError(folder, "holds no scenario (a folder of annotations, or a <case>.txt image list)")
    return found


def _scenario(path: Path, index: dict[str, int]) -> np.ndarray:
    """The mask of one scenario's frames among the scored ones (`index`: relpath -> position)."""
    listed = read_list(path) if path.suffix == ".txt" else _every_label(path)
    outside = [relpath for relpath in listed if relpath not in index]
    if outside:
        raise InputError(path, f"holds {outside[0]}, which is not among the images scored"
                               + (f" (and {len(outside) - 1} more)" if len(outside) > 1 else ""))
    mask = np.zeros(len(index), bool)
    mask[[index[relpath] for relpath in listed]] = True
    return mask


def score_openlane3d(labels: str | Path, pred_root: PredictionRoots, list_file: str | Path | None = None,
                     scenarios: str | Path | None = None, protocol: str = "file",
                     prob_threshold: float | None = None, out: str | Path | None = None,
                     workers: int | None = None, progress: bool = False, announce: Callable[[str], None] | None = None,
                     strict: bool = False, shard: str | None = None,
                     merged: Merged | None = None) -> OpenLane3dScore | None:
    """Score OpenLane 3D result files mirroring `labels` (`<segment>/<frame>.json`), the images of
    `list_file` (its test_list.txt; default every annotation), over them all and over each scenario
    in `scenarios`. `protocol`: "file" (OpenLane's and PersFormer's bench_one_submit: every lane of
    `lane_lines`) or "persformer-train" (PersFormer's training-time evaluation: `laneLines` with
    `laneLines_prob`, a lane kept when its highest probability is above `prob_threshold`, its
    category the most probable). With `shard` ('I/N'), only that share of the segments, written as
    a part to `out` (None is returned)."""
    threshold = check_protocol(protocol, prob_threshold)
    sharding = Sharding("score openlane3d", shard, out, merged, dict(
        labels=labels, pred_root=pred_root, list_file=list_file, scenarios=scenarios, protocol=protocol,
        prob_threshold=prob_threshold, strict=strict), paths=("labels", "list_file", "scenarios"))
    labels = Path(labels)
    with _taking(out, "score openlane3d", reads=(labels, list_file, scenarios)) as folder:
        relpaths = read_list(Path(list_file)) if list_file is not None else _every_label(labels)
        groups = _scenarios(scenarios, relpaths)
        trees, warnings = find_prediction_trees(pred_root, relpaths, strict, announce, suffix=".json")
        warnings += stopping_gaps(trees, file="result file")
        label_files = [json_path(labels, relpath) for relpath in relpaths]

        def files_of(m: int, relpath: str) -> tuple[Path]:
            return (json_path(trees[m].root, relpath),)

        if merged is not None:
            sharding.check_merged(relpaths, trees, label_files, posixpath.dirname, files_of=files_of)
            stats, errors = _merged(sharding, len(relpaths), len(trees))
        else:
            scored = sharding.share(relpaths, posixpath.dirname)  # a segment is a clip
            stats, errors = _scored(scored, labels, trees, threshold, workers, progress, announce)
            if sharding.shard is not None:
                assert folder is not None
                tagged = [np.column_stack([np.full(len(found), float(m)), found]) for m, found in enumerate(errors)]
                sharding.write_part(folder, relpaths, trees, label_files, scored,
                                    {"cat_stats": stats, "cat_errors": np.concatenate(tagged or [np.zeros((0, 5))])},
                                    files_of=files_of)
                return None
        if lane3d_flow.flow_solver() is None:
            warnings.append(lane3d_flow.NO_ORTOOLS_WARNING)
        score = OpenLane3dScore(_table(trees, groups, stats, errors), tuple(tree.method for tree in trees),
                                tuple(groups), len(relpaths), tuple(warnings), protocol, threshold)
        write_texts(folder, {"official.csv": score.rows.to_csv(), "summary.md": summary_markdown(score)})
    return score


def _scored(scored: Sequence[str], labels: Path, trees, prob_threshold: float | None, workers: int | None,
            progress: bool, announce: Callable[[str], None] | None) -> tuple[np.ndarray, list[np.ndarray]]:
    """(frames, methods, 6) counts of the frames `scored`, and per method its matches' errors."""
    chunks = [scored[i:i + CHUNK_FRAMES] for i in range(0, len(scored), CHUNK_FRAMES)]
    roots = tuple(tree.root for tree in trees)
    pieces = scored_pieces(_score_frames, [(chunk, labels, roots, prob_threshold) for chunk in chunks], workers,
                           progress, announce, kernel_groups=(), trees=trees)
    _once_each([key for piece in pieces for key in piece[2]], scored, labels)
    stats = np.concatenate([piece[0] for piece in pieces]) if pieces else np.zeros((0, len(trees), 6))
    errors = [np.concatenate([piece[1][m] for piece in pieces]) if pieces else np.zeros((0, 4))
              for m in range(len(trees))]
    return stats, errors


def _merged(sharding: Sharding, n_frames: int, n_methods: int) -> tuple[np.ndarray, list[np.ndarray]]:
    """What _scored gives, from the parts: each frame's counts and each match's errors (tagged with
    its method), concatenated in shard order, which is list order."""
    stats = sharding.merged_array("cat_stats", (n_frames, n_methods, 6), kind="f")
    matched = sharding.merged_array("cat_errors", (int(stats[:, :, 5].sum()), 5), kind="f")
    return stats, [matched[matched[:, 0] == m, 1:] for m in range(n_methods)]


def _every_label(labels: Path) -> list[str]:
    """`<segment>/<frame>.jpg` for every `<segment>/<frame>.json` below `labels`, sorted."""
    from ...datasets._paths import check_folder, files_below, frame_sort_key

    check_folder(labels, "annotation folder not found")
    found = files_below(labels, ".json", frame_sort_key)
    if not found:
        raise InputError(labels, "no <segment>/<frame>.json here: is this OpenLane's lane3d annotation folder?")
    return [relpath[:-len(".json")] + ".jpg" for relpath in found]


def _table(trees, groups: dict[str, np.ndarray], stats: np.ndarray, errors: list[np.ndarray]) -> PlainTable:
    """A row per method and scenario: its frames, the six sums and the eight printed numbers."""
    rows = []
    for m, tree in enumerate(trees):
        matches = stats[:, m, 5].astype(int)
        owner = np.repeat(np.arange(len(matches)), matches)  # the frame of each match, in order
        for name, inside in groups.items():
            values = totals(stats[inside, m], errors[m][inside[owner]])
            rows.append((tree.method, name, int(inside.sum()), *(int(v) for v in values[8:]), *values[:8]))
    return PlainTable(COLUMNS, tuple(rows))


def printed(value: float) -> str:
    """A number as the evaluator prints it: Python's `{:.8}`."""
    return f"{value:.8}"


def summary_table(score: OpenLane3dScore) -> str:
    head = ["method", "scenario", "F", "recall", "precision", "category acc.", "x near (m)", "x far (m)",
            "z near (m)", "z far (m)"]
    lines = ["| " + " | ".join(head) + " |", "|---" * len(head) + "|"]
    for row in score.rows.rows:
        values = row[3 + len(SUMS):]
        lines.append(f"| {row[0]} | {row[1]} | " + " | ".join(printed(v) for v in values) + " |")
    return "\n".join(lines)


def summary_markdown(score: OpenLane3dScore) -> str:
    return ("# OpenLane 3D, official protocol\n\n"
            f"{score.n_frames:,} images, scored as OpenLane's lane3d evaluator (eval_3D_lane.py, 8a0ce6b; "
            f"{score.describe()}; lanes matched by {lane3d_flow.matcher()}). A match counts "
            "below an integer cost of 150 (1.5 m over 100 samples, y 3-102 m); recall and precision at 75% of a "
            "lane's visible samples within 1.5 m; x/z errors near y <= 40 m and far beyond, over the samples both "
            "lanes see. Printed as the evaluator prints them ({:.8}).\n\n" + summary_table(score) + "\n"
            + "".join(f"\n{line}\n" for line in score.warnings))


def check_protocol(protocol: str, prob_threshold: float | None) -> float | None:
    """The probability a lane's highest class must exceed (None: the file protocol keeps every lane)."""
    if protocol not in PROTOCOLS:
        raise ConfigError(f"--protocol {protocol!r}: choose from {', '.join(PROTOCOLS)}")
    if protocol == "file":
        if prob_threshold is not None:
            raise ConfigError("--prob-threshold is for --protocol persformer-train (the file protocol keeps every "
                              "lane)")
        return None
    threshold = PROB_THRESHOLD if prob_threshold is None else prob_threshold
    if not (isinstance(threshold, (int, float)) and 0.0 <= threshold <= 1.0):
        raise ConfigError(f"--prob-threshold {prob_threshold!r} must be a probability, from 0 to 1")
    return float(threshold)
