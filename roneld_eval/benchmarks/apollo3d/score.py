"""`score apollo3d`: Apollo 3D Synthetic predictions scored as Gen-LaneNet's evaluator scores them
(45c6cc4, tools/eval_3D_lane.py, its `__main__`): AP and the F of the lane-line probability
threshold chosen on the test set, with recall, precision and the x/z errors near (0-40 m) and far
(40-100 m) there, for lane lines and for centre lines (official.py). Several prediction files are
several methods, scored against one reading of the labels.

official.csv has a row per method and lane type: the threshold, the five sums at it (recalled,
precise, ground-truth lanes, predicted lanes, matches) and the numbers; sweep.csv every threshold's
sums, recall, precision and F; summary.md the evaluator's printed lines (`{:.3}`) beside them.
"""

from __future__ import annotations

import os
import posixpath
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from ...errors import InputError
from ...metrics import lane3d_flow
from ...scoring import PlainTable, write_texts, _root_specs, _taking, check_method_names, scored_pieces
from ...shards import Merged, Sharding
from .official import COUNTS, LANE_TYPES, THRESHOLDS, chosen_threshold, frame_sweep, printed_line, totals
from .reader import Predicted, Truth, prediction_of, records, truth_of

NUMBERS = ("ap", "f", "recall", "precision", "x_error_near", "x_error_far", "z_error_near", "z_error_far")
COLUMNS = ("method", "lane_type", "frames", "threshold", *COUNTS, *NUMBERS)
SWEEP_COLUMNS = ("method", "lane_type", "threshold", *COUNTS[:4], "recall", "precision", "f")
TITLES = {"laneline": "Laneline", "centerline": "Centerline"}
HEADER = "Metrics: AP, F-score, x error (close), x error (far), z error (close), z error (far)"
CHUNK_FRAMES = 100


@dataclass(frozen=True)
class Apollo3dScore:
    """official.csv's rows, sweep.csv's, and the evaluator's printed lines of each method."""

    rows: PlainTable
    sweep: PlainTable
    methods: tuple[str, ...]
    n_frames: int
    printed: dict[str, tuple[str, ...]]
    warnings: tuple[str, ...] = ()

    def value(self, method: str, column: str, lane_type: str = "laneline") -> Any:
        at = COLUMNS.index(column)
        return next(row[at] for row in self.rows.rows if row[0] == method and row[1] == lane_type)


def score_apollo3d(labels: str | Path, pred: Any, out: str | Path | None = None, workers: int | None = None,
                   progress: bool = False, announce: Callable[[str], None] | None = None, shard: str | None = None,
                   merged: Merged | None = None) -> Apollo3dScore | None:
    """Score Apollo 3D Synthetic JSON-lines predictions against a label file (a split's test.json)
    as Gen-LaneNet's eval_3D_lane.py does. `pred`: one file, or several (each a method named by its
    file's stem, or 'NAME=FILE', or a mapping of name to file). With `shard` ('I/N'), only that
    share of the clips (image folders, in label-file order), written as a part to `out` (None is
    returned)."""
    methods = _methods(pred)
    sharding = Sharding("score apollo3d", shard, out, merged, dict(labels=labels, pred=_recorded(pred)),
                        paths=("labels",), roots=())
    labels = Path(labels)
    with _taking(out, "score apollo3d", reads=(labels, *methods.values())) as folder:
        keys, truths = _read_labels(labels)
        orders, predictions, kinds, warnings = _read_predictions(labels, methods, keys, truths)
        files = [labels, *methods.values()]
        if merged is not None:
            sharding.check_merged(keys, [], files, posixpath.dirname, files_of=None)  # the files: among `files`
            counts = sharding.merged_array("cat_counts", (len(keys), len(methods), 2, len(THRESHOLDS), len(COUNTS)),
                                           "f", within=(0, 1e9))
            errors = sharding.merged_array("cat_errors", (int(counts[..., 4].sum()), 8), "f")
        else:
            share = sharding.share(keys, posixpath.dirname)  # a clip: a folder of images
            counts, errors = _scored(share, keys, truths, predictions, kinds, list(methods.values()), workers,
                                     progress, announce)
            if sharding.shard is not None:
                assert folder is not None
                sharding.write_part(folder, keys, [], files, share, {"cat_counts": counts, "cat_errors": errors},
                                    files_of=None)
                return None
        if lane3d_flow.flow_solver() is None:
            warnings.append(lane3d_flow.NO_ORTOOLS_WARNING)
        score = _score(list(methods), kinds, orders, counts, errors, len(keys), warnings)
        write_texts(folder, {"official.csv": score.rows.to_csv(), "sweep.csv": score.sweep.to_csv(),
                             "summary.md": summary_markdown(score)})
    return score


def _methods(pred: Any) -> dict[str, Path]:
    """Each method's prediction file: named by its stem, or as given ('NAME=FILE', a mapping)."""
    named = [(name or Path(path).stem, Path(path)) for name, path in _root_specs(pred)]
    check_method_names(named, "--pred NAME=FILE", "prediction files")
    return dict(named)


def _recorded(pred: Any) -> str | list[str]:
    """The prediction files as a part records them: as given (one, or several), made absolute."""
    texts = [os.path.abspath(path) if name is None else f"{name}={os.path.abspath(path)}"
             for name, path in _root_specs(pred)]
    return texts[0] if isinstance(pred, (str, Path)) else texts


def _read_labels(labels: Path) -> tuple[list[str], list[Truth]]:
    """Every labelled frame's raw_file, in file order, and its lanes (a frame labelled twice refused:
    the evaluator keeps the last of them and would score the other frame's predictions against it)."""
    keys: list[str] = []
    truths: list[Truth] = []
    seen: dict[str, int] = {}
    for number, key, record in records(labels):
        if key in seen:
            raise InputError(labels, f"{key} is labelled twice (first on line {seen[key]})", line=number)
        seen[key] = number
        keys.append(key)
        truths.append(truth_of(record, labels, number))
    centres = [truth.lanes["centerline"] is not None for truth in truths]
    if any(centres) and not all(centres):
        raise InputError(labels, "has no `centerLines` where other lines have them (the evaluator stops on it)",
                         line=next(seen[key] for key, has in zip(keys, centres) if not has))
    return keys, truths


def _read_predictions(labels: Path, methods: dict[str, Path], keys: Sequence[str], truths: Sequence[Truth]
                      ) -> tuple[list[np.ndarray], list[list[Predicted]], list[tuple[str, ...]], list[str]]:
    """Per method: the label index of each of its lines (its order, which the averages follow), its
    predictions in label order, the lane types it is scored on, and a warning where that is lane
    lines only."""
    index = {key: k for k, key in enumerate(keys)}
    labelled_centres = all(truth.lanes["centerline"] is not None for truth in truths)
    orders, predictions, kinds, warnings = [], [], [], []
    for method, path in methods.items():
        order, found = _one_file(labels, path, index)
        orders.append(order)
        predictions.append(found)
        kinds.append(_lane_types(path, order, found, labelled_centres))
        if len(kinds[-1]) == 1:
            whose = "its predictions" if labelled_centres else "the labels"
            warnings.append(f"warning: {method}: lane lines only, as {whose} have no centerLines (Gen-LaneNet's "
                            "evaluator stops without them; its lane-line numbers do not depend on them)")
    return orders, predictions, kinds, warnings


def _one_file(labels: Path, path: Path, index: dict[str, int]) -> tuple[np.ndarray, list[Predicted]]:
    """A prediction file's label index of each line, and its predictions in label order: every
    labelled frame once (the evaluator counts lines, and pairs a frame predicted twice twice)."""
    order: list[int] = []
    found: list[Predicted | None] = [None] * len(index)
    for number, key, record in records(path):
        k = index.get(key)
        if k is None:
            raise InputError(path, f"{key} is not in the labels ({labels.name})", line=number)
        if found[k] is not None:
            raise InputError(path, f"{key} is predicted twice", line=number)
        found[k] = prediction_of(record, path, number)
        order.append(k)
    if len(order) < len(index):
        missing = next(key for key, k in index.items() if found[k] is None)
        raise InputError(path, f"no prediction for {len(index) - len(order)} of {len(index)} labelled frames (first: "
                               f"{missing}); the evaluator stops on it")
    return np.array(order), [value for value in found if value is not None]


def _lane_types(path: Path, order: np.ndarray, found: list[Predicted], labelled_centres: bool) -> tuple[str, ...]:
    """Both lane types, or lane lines alone where the file (or the labels) have no centre lines."""
    centres = [value.lanes["centerline"] is not None for value in found]
    if any(centres) and not all(centres):
        first = next(line for line, k in enumerate(order.tolist(), start=1) if not centres[k])
        raise InputError(path, "has no `centerLines` where other lines have them (the evaluator stops on it)",
                         line=first)
    return LANE_TYPES if all(centres) and labelled_centres else LANE_TYPES[:1]


def _score_frames(task) -> tuple[np.ndarray, np.ndarray]:
    """The counts of a chunk of frames (frames, methods, 2, 19, 5) and its counted matches' errors,
    a row each: method, frame (its label index), lane type, threshold, x near, x far, z near, z far."""
    positions, keys, truths, predictions, kinds, files = task
    counts = np.zeros((len(positions), len(kinds), 2, len(THRESHOLDS), len(COUNTS)))
    rows: list[np.ndarray] = []
    for f, (position, truth) in enumerate(zip(positions, truths)):
        for m, method_kinds in enumerate(kinds):
            predicted = predictions[m][f]
            for t, kind in enumerate(method_kinds):
                try:
                    sweep = frame_sweep(predicted.lanes[kind], predicted.probabilities[kind],
                                        truth.lanes[kind] or (), truth.visibility[kind] or ())
                except ValueError as error:  # a distance beyond the integer cost
                    raise InputError(files[m], f"{keys[f]}: {error}") from None
                counts[f, m, t] = sweep.counts
                rows.append(_tagged(sweep.errors, m, position, t))
    return counts, np.concatenate(rows) if rows else np.zeros((0, 8))


def _tagged(errors: Sequence[np.ndarray], method: int, frame: int, kind: int) -> np.ndarray:
    """A frame's errors at each threshold as rows: method, frame, lane type, threshold, the four errors."""
    at = np.repeat(np.arange(len(errors)), [len(found) for found in errors])
    tags = np.column_stack([np.full(len(at), method), np.full(len(at), frame), np.full(len(at), kind), at])
    return np.column_stack([tags, np.concatenate(errors)]) if len(at) else np.zeros((0, 8))


def _scored(share: Sequence[str], keys: Sequence[str], truths: Sequence[Truth], predictions, kinds, files, workers,
            progress, announce) -> tuple[np.ndarray, np.ndarray]:
    position = {key: k for k, key in enumerate(keys)}
    scored = [position[key] for key in share]
    tasks = [(chunk, [keys[k] for k in chunk], [truths[k] for k in chunk],
              [[found[k] for k in chunk] for found in predictions], kinds, files)
             for chunk in (scored[i:i + CHUNK_FRAMES] for i in range(0, len(scored), CHUNK_FRAMES))]
    pieces = scored_pieces(_score_frames, tasks, workers, progress, announce, kernel_groups=())
    counts = (np.concatenate([piece[0] for piece in pieces]) if pieces
              else np.zeros((0, len(kinds), 2, len(THRESHOLDS), len(COUNTS))))
    errors = np.concatenate([piece[1] for piece in pieces]) if pieces else np.zeros((0, 8))
    return counts, errors


def _score(methods: list[str], kinds, orders, counts: np.ndarray, errors: np.ndarray, n_frames: int,
           warnings: list[str]) -> Apollo3dScore:
    rows, sweep_rows, printed = [], [], {}
    for m, method in enumerate(methods):
        lines = [HEADER]
        rank = np.empty(n_frames, dtype=int)
        rank[orders[m]] = np.arange(n_frames)  # a frame's place in the method's file
        best = chosen_threshold(counts[orders[m], m, 0])  # the lane lines' choice, for both types
        for t, kind in enumerate(kinds[m]):
            ordered = counts[orders[m], m, t]
            chosen = errors[(errors[:, 0] == m) & (errors[:, 2] == t) & (errors[:, 3] == best)]
            chosen = chosen[np.argsort(rank[chosen[:, 1].astype(int)], kind="stable"), 4:]
            total = totals(ordered, chosen, best)
            sums = ordered[:, best, :].sum(axis=0)
            rows.append((method, kind, n_frames, float(THRESHOLDS[best]), *(int(v) for v in sums), total.ap,
                         *total.at_best, *total.errors))
            sweep_sums = ordered.sum(axis=0)
            sweep_rows += [(method, kind, float(THRESHOLDS[k]), *(int(v) for v in sweep_sums[k, :4]),
                            float(total.recall[k]), float(total.precision[k]), float(total.f[k]))
                           for k in range(len(THRESHOLDS))]
            lines.append(printed_line(TITLES[kind], total))
        printed[method] = tuple(lines)
    return Apollo3dScore(PlainTable(COLUMNS, tuple(rows)), PlainTable(SWEEP_COLUMNS, tuple(sweep_rows)),
                         tuple(methods), n_frames, printed, tuple(warnings))


def summary_markdown(score: Apollo3dScore) -> str:
    parts = ["# Apollo 3D Synthetic, official protocol\n\n"
             f"{score.n_frames:,} images, scored as Gen-LaneNet's evaluator (tools/eval_3D_lane.py, 45c6cc4; lanes "
             f"matched by {lane3d_flow.matcher()}). AP over the lane probability thresholds 0.05, 0.10, ..., 0.95; "
             "F, recall, precision and the x/z errors near (y <= 40 m) and far at the threshold of the highest "
             "lane-line F, **chosen on the test set** as the evaluator's `__main__` chooses it (centre lines at the "
             "same threshold). The evaluator's own lines follow each table ({:.3}).\n"]
    for method in score.methods:
        parts.append(f"\n## {method}\n\n| lane type | threshold | AP | F | recall | precision | x near (m) | "
                     "x far (m) | z near (m) | z far (m) |\n|---|---|---|---|---|---|---|---|---|---|\n")
        for row in score.rows.rows:
            if row[0] == method:
                numbers = row[4 + len(COUNTS):]
                parts.append(f"| {row[1]} | {row[3]:.2f} | " + " | ".join(f"{v:.4f}" for v in numbers) + " |\n")
        parts.append("\n```\n" + "\n".join(score.printed[method]) + "\n```\n")
    return "".join(parts) + "".join(f"\n{line}\n" for line in score.warnings)


__all__ = ["score_apollo3d", "Apollo3dScore", "COLUMNS"]
