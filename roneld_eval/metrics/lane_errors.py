"""Why a lane-IoU F1 is not higher: each false positive and false negative given one error type,
TIDE's method (Bolya et al., ECCV 2020) carried over to lanes matched by IoU.

At a threshold t a matched pair with IoU > t is a true positive (the official rule); every other
prediction is a false positive and every other ground-truth lane a false negative. A false-positive
prediction takes its highest-IoU ground-truth lane (the first of equal ones):

- **Loc** if that IoU is at least `loc_iou` and that lane is not a true positive: the prediction
  found the lane but drew it too far off. Of several such predictions on one lane, the one of
  highest IoU is Loc (the first of equal ones) and the others Dupe;
- **Dupe** if that lane is already a true positive;
- **Bkg** if no IoU reaches `loc_iou` (or the frame has no ground truth).

Where lanes match only lanes of their own category (OpenLane's default), a false positive that would
match a lane of another category (IoU > t with it) is **Cat**, before the rules above (TIDE's
order: its classification error comes first), and only lanes of its own category count for them.

A false-negative lane is **Loc** when it is some Loc prediction's lane, else **Miss**. So the false
positives' types add up to FP and the false negatives' to FN exactly, and each Loc prediction has
one Loc lane. The change in F1 when every error of one type is fixed (`delta_f1`) is how TIDE
gives its dAP: a Loc pair becomes a true positive (FP and FN one less each, TP one more), a Dupe,
Cat or Bkg prediction is removed (FP one less), a Miss is removed (FN one less).

`frame_errors` counts a frame at every threshold in one kernel call (_kernels.lane_error_counts);
`classify` is the same rule written plainly, one threshold, naming each lane's type (its twin).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Iterable, Sequence

import numpy as np

from .. import _numba_cache  # noqa: F401  (numba imported first, a signal deferred meanwhile)
from . import _kernels
from .iou import KM_TOLERANCE, match_lanes
from .lane_iou_f1 import f_measure

# (side, type) of each column of frame_errors' counts, in order
ERROR_TYPES = (("fp", "Loc"), ("fp", "Dupe"), ("fp", "Cat"), ("fp", "Bkg"), ("fn", "Loc"), ("fn", "Miss"))
ERROR_COLUMNS = tuple(f"{side}_{kind.lower()}" for side, kind in ERROR_TYPES)  # frames.csv.gz's: fp_loc, ...
CAT = ERROR_TYPES.index(("fp", "Cat"))
DEFAULT_LOC_IOU = 0.1


@dataclass(frozen=True)
class FrameErrors:
    """One frame's matching and its error types: each ground-truth lane's matched IoU (-inf
    where unmatched, as FrameMatches holds it), and (thresholds, 6) counts in ERROR_TYPES order."""

    n_gt: int
    n_pred: int
    matched_iou: np.ndarray
    counts: np.ndarray


@dataclass(frozen=True)
class ScoreSweep:
    """Score thresholds a sweep keeps predictions at: `labels` as given, `limits` their values;
    a lane is kept when its score >= the threshold (> when `strict`, as a benchmark's own rule may be)."""

    labels: tuple[str, ...]
    limits: np.ndarray
    strict: bool = False

    @property
    def rule(self) -> str:
        return "score > threshold" if self.strict else "score >= threshold"


@dataclass(frozen=True, eq=False)
class DiagnosisSettings:
    """What a score diagnoses: the IoU thresholds' values, --loc-iou, the score sweep (None
    without --score-sweep) and whether the error types are written (--diagnose)."""

    limits: np.ndarray
    loc_iou: float
    sweep: ScoreSweep | None
    errors: bool


DEFAULT_SCORE_SWEEP = "0.00:0.95:0.05"


def diagnosis_settings(diagnose: bool, loc_iou: float | None, score_sweep: str | None, limits: Sequence[float],
                       strict: bool = False) -> DiagnosisSettings | None:
    """The settings of --diagnose/--loc-iou/--score-sweep (None when neither is asked for); a
    ConfigError line for a --loc-iou outside (0, 1] or given alone."""
    from ..errors import ConfigError
    from ..thresholds import parse_thresholds

    if loc_iou is not None and not diagnose:
        raise ConfigError("--loc-iou sets what --diagnose calls a localisation error: give --diagnose too")
    loc = DEFAULT_LOC_IOU if loc_iou is None else float(loc_iou)
    if not 0.0 < loc <= 1.0:
        raise ConfigError(f"--loc-iou {loc_iou} must be in (0, 1]")
    if not diagnose and score_sweep is None:
        return None
    sweep = None
    if score_sweep is not None:
        try:
            grid = parse_thresholds(score_sweep)
        except ConfigError as error:  # its wording is of IoU thresholds
            raise ConfigError(f"--score-sweep {score_sweep}: {str(error).replace('IoU thresholds', 'score thresholds')}"
                              ) from None
        sweep = ScoreSweep(grid.labels, np.array(grid.values, np.float64), strict)
    return DiagnosisSettings(np.array(limits, np.float64), loc, sweep, diagnose)


def frame_errors(similarity: np.ndarray, limits: np.ndarray, loc_iou: float, match: np.ndarray | None = None,
                 other_iou: np.ndarray | None = None) -> FrameErrors:
    """A (ground truth, predictions) IoU matrix's matching (SCNN's evaluator's unless `match`
    gives a benchmark's own: each ground-truth lane's prediction, -1 for none) and its error types
    at each threshold of `limits`; `other_iou` where lanes match only lanes of their own category
    (category_iou)."""
    matrix = np.ascontiguousarray(similarity, np.float64)
    n_gt, n_pred = matrix.shape
    if match is None:
        rows, columns = np.arange(n_gt, dtype=np.int64), np.arange(n_pred, dtype=np.int64)
        match = _kernels.matched_columns(matrix, rows, columns, KM_TOLERANCE)
    match = np.ascontiguousarray(match, np.int64)
    matched = np.full(n_gt, -np.inf)
    found = np.flatnonzero(match >= 0)
    matched[found] = matrix[found, match[found]]
    other = np.full(n_pred, -np.inf) if other_iou is None else np.ascontiguousarray(other_iou, np.float64)
    counts = _kernels.lane_error_counts(matrix, match, other, np.ascontiguousarray(limits, np.float64), float(loc_iou))
    return FrameErrors(n_gt, n_pred, matched, counts)


def category_iou(similarity: np.ndarray, same: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(the IoUs as lanes of one category match them: 0 across categories, each prediction's
    highest IoU with a lane of another category (-inf without one)) from every pair's IoU and
    whether the pair's categories agree."""
    across = np.where(same, -np.inf, np.nan_to_num(similarity, nan=-np.inf))
    other = across.max(axis=0) if similarity.shape[0] else np.full(similarity.shape[1], -np.inf)
    return np.where(same, similarity, 0.0), other


def swept_frame(similarity: np.ndarray, scores: np.ndarray, sweep: ScoreSweep,
                limits: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(true positives (score thresholds, IoU thresholds), predictions kept (score thresholds,)) of
    a frame whose predictions have these scores: at each score threshold the lanes kept are
    matched again, as the official evaluator would match a file holding only them."""
    return _kernels.swept_true_positives(np.ascontiguousarray(similarity, np.float64),
                                         np.ascontiguousarray(scores, np.float64), sweep.limits,
                                         np.ascontiguousarray(limits, np.float64), sweep.strict, KM_TOLERANCE)


def classify(similarity: np.ndarray, threshold: float, loc_iou: float, match: np.ndarray | None = None,
             other_iou: np.ndarray | None = None) -> tuple[list[str], list[str]]:
    """Each prediction's and each ground-truth lane's outcome at one threshold: "TP", or its
    error type ("Loc", "Dupe", "Cat", "Bkg"; "Loc", "Miss"). The rule of the module's docstring,
    plainly; `match` and `other_iou` as frame_errors takes them."""
    n_gt, n_pred = similarity.shape
    if match is None:
        match = match_lanes(similarity) if n_gt and n_pred else np.full(n_gt, -1)
    gt_hit = [bool(match[g] >= 0 and similarity[g, match[g]] > threshold) for g in range(n_gt)]
    matched = {int(match[g]) for g in range(n_gt) if gt_hit[g]}
    preds = ["TP" if p in matched else "" for p in range(n_pred)]
    other = np.full(n_pred, -np.inf) if other_iou is None else other_iou
    candidates = _false_positives(similarity, gt_hit, preds, loc_iou, other > threshold)
    _one_loc_a_lane(candidates, preds)
    truth = ["TP" if gt_hit[g] else ("Loc" if g in candidates else "Miss") for g in range(n_gt)]
    return preds, truth


def _false_positives(similarity: np.ndarray, gt_hit: list[bool], preds: list[str], loc_iou: float,
                     other_category: np.ndarray) -> dict[int, list[tuple[float, int]]]:
    """Cat (where `other_category` says a lane of another category would match), Bkg and Dupe
    given to the unmatched predictions of `preds`, by their highest-IoU lane; the others, found
    off an unmatched lane, returned by lane as (IoU, prediction)."""
    candidates: dict[int, list[tuple[float, int]]] = {}
    for p in (p for p in range(len(preds)) if not preds[p]):
        g, iou = _highest_iou_lane(similarity[:, p])
        if other_category[p]:
            preds[p] = "Cat"
        elif g < 0 or not iou >= loc_iou:
            preds[p] = "Bkg"
        elif gt_hit[g]:
            preds[p] = "Dupe"
        else:
            candidates.setdefault(g, []).append((iou, p))
    return candidates


def _one_loc_a_lane(candidates: dict[int, list[tuple[float, int]]], preds: list[str]) -> None:
    """Of the predictions found off one lane, the highest IoU (the first of equal ones) is Loc."""
    for found in candidates.values():
        top = max(iou for iou, _ in found)
        chosen = min(p for iou, p in found if iou == top)
        for _, p in found:
            preds[p] = "Loc" if p == chosen else "Dupe"


def _highest_iou_lane(ious: np.ndarray) -> tuple[int, float]:
    """(the first ground-truth lane of highest IoU, that IoU), a NaN counting as none; (-1, -inf)
    without any."""
    values = [-np.inf if np.isnan(v) else float(v) for v in ious]
    if not values or max(values) == -np.inf:
        return -1, -np.inf
    g = int(np.argmax(values))
    return g, values[g]


Measure = Callable[[int, int, int], tuple[float, float, float]]  # (tp, fp, fn) -> (precision, recall, F1)


def delta_f1(tp: int, fp: int, fn: int, counts: Sequence[int], measure: Measure = f_measure) -> list[float]:
    """dF1 of each error type (ERROR_TYPES order) from summed counts: F1 with every error of that
    type fixed, minus F1 as it is (NaN where F1 is undefined either way)."""
    f1 = measure(tp, fp, fn)[2]
    loc, dupe, cat, bkg, _, miss = (int(c) for c in counts)
    fixed = [(tp + loc, fp - loc, fn - loc), (tp, fp - dupe, fn), (tp, fp - cat, fn), (tp, fp - bkg, fn),
             (tp + loc, fp - loc, fn - loc), (tp, fp, fn - miss)]
    return [measure(*after)[2] - f1 for after in fixed]


@dataclass(frozen=True, eq=False)
class FrameDiagnoses:
    """Per-frame counts of one or more methods on the same frames, in scoring order: what
    errors.csv, frames.csv.gz and sweep_scores.csv are summed from."""

    frames: tuple[str, ...]
    n_gt: np.ndarray  # (frames,)
    n_pred: np.ndarray  # (methods, frames)
    tp: np.ndarray  # (methods, frames, thresholds)
    errors: np.ndarray  # (methods, frames, thresholds, error types), ERROR_TYPES order
    sweep_tp: np.ndarray | None = None  # (methods, frames, score thresholds, thresholds)
    sweep_kept: np.ndarray | None = None  # (methods, frames, score thresholds)

    @classmethod
    def of_frames(cls, frames: Sequence[str], per_method: Sequence[Sequence[FrameErrors]], limits: np.ndarray,
                  swept: Sequence[Sequence[tuple[np.ndarray, np.ndarray]]] | None = None) -> "FrameDiagnoses":
        """From each method's FrameErrors of these frames (and their swept_frame results)."""
        n_methods, n_frames, n_limits = len(per_method), len(frames), len(limits)
        n_gt = np.array([errors.n_gt for errors in per_method[0]], np.int64) if n_methods else np.zeros(n_frames,
                                                                                                        np.int64)
        n_pred = np.array([[e.n_pred for e in errors] for errors in per_method], np.int64).reshape(n_methods, n_frames)
        tp = np.array([[np.count_nonzero(e.matched_iou[None, :] > limits[:, None], axis=1) for e in errors]
                       for errors in per_method], np.int64).reshape(n_methods, n_frames, n_limits)
        counts = np.array([[e.counts for e in errors] for errors in per_method], np.int64)
        counts = counts.reshape(n_methods, n_frames, n_limits, len(ERROR_TYPES))
        if swept is None:
            return cls(tuple(frames), n_gt, n_pred, tp, counts)
        sweep_tp = np.array([[one[0] for one in method] for method in swept], np.int64)
        sweep_kept = np.array([[one[1] for one in method] for method in swept], np.int64)
        n_scores = sweep_kept.shape[-1] if sweep_kept.size else 0
        return cls(tuple(frames), n_gt, n_pred, tp, counts, sweep_tp.reshape(n_methods, n_frames, n_scores, n_limits),
                   sweep_kept.reshape(n_methods, n_frames, n_scores))


def joined_diagnoses(pieces: Iterable[FrameDiagnoses | None]) -> FrameDiagnoses | None:
    """A scorer's chunks' diagnoses as one, frames in order (None where no chunk has any: no
    diagnosis, or a shard without frames)."""
    found = [piece for piece in pieces if piece is not None]
    if not found:
        return None
    swept = all(piece.sweep_tp is not None for piece in found)
    return FrameDiagnoses(tuple(frame for piece in found for frame in piece.frames),
                          np.concatenate([p.n_gt for p in found]), np.concatenate([p.n_pred for p in found], axis=1),
                          np.concatenate([p.tp for p in found], axis=1),
                          np.concatenate([p.errors for p in found], axis=1),
                          _joined([p.sweep_tp for p in found]) if swept else None,
                          _joined([p.sweep_kept for p in found]) if swept else None)


def split_diagnosed(pieces: list, settings: DiagnosisSettings | None) -> tuple[list, FrameDiagnoses | None]:
    """(each chunk's counts, their diagnoses joined) of a scorer's chunks, which are (counts,
    diagnoses) when it diagnoses and counts alone when not."""
    if settings is None:
        return pieces, None
    return [piece[0] for piece in pieces], joined_diagnoses(piece[1] for piece in pieces)


class DiagnosisCollector:
    """A chunk's per-frame error types (and score sweeps) as a scorer meets its frames, method by
    method: nothing is computed without settings (no --diagnose, no --score-sweep)."""

    def __init__(self, settings: DiagnosisSettings | None, n_methods: int):
        self.settings = settings
        self.errors: list[list[FrameErrors]] = [[] for _ in range(n_methods)]
        self.swept: list[list[tuple[np.ndarray, np.ndarray]]] = [[] for _ in range(n_methods)]

    def add(self, m: int, similarity: Callable[[], np.ndarray], scores: Callable[[], Sequence[float]] | None = None,
            match: np.ndarray | None = None, other_iou: np.ndarray | None = None) -> FrameErrors | None:
        """Method m's next frame from its (ground truth, predictions) IoUs, asked for only here, and
        its lanes' scores where a sweep needs them; the frame's FrameErrors (None without settings)."""
        settings = self.settings
        if settings is None:
            return None
        matrix = similarity()
        errors = frame_errors(matrix, settings.limits, settings.loc_iou, match, other_iou)
        self.errors[m].append(errors)
        if settings.sweep is not None and scores is not None:
            self.swept[m].append(swept_frame(matrix, np.array(scores(), np.float64), settings.sweep, settings.limits))
        return errors

    def add_swept(self, m: int, true_positives: np.ndarray, kept: np.ndarray) -> None:
        """Method m's frame at each score threshold where a benchmark counts it itself: (score
        thresholds, IoU thresholds) true positives and (score thresholds,) predictions kept."""
        if self.settings is not None and self.settings.sweep is not None:
            self.swept[m].append((np.asarray(true_positives, np.int64), np.asarray(kept, np.int64)))

    def result(self, frames: Sequence[str]) -> FrameDiagnoses | None:
        if self.settings is None:
            return None
        swept = self.swept if self.settings.sweep is not None and all(self.swept) else None
        return FrameDiagnoses.of_frames(frames, self.errors, self.settings.limits, swept)


def kernel_groups(groups: tuple[str, ...], settings: DiagnosisSettings | None) -> tuple[str, ...]:
    """A scorer's kernel groups, and the diagnosis' when it diagnoses."""
    return groups if settings is None else groups + ("diagnosis",)


def _sizes(settings: DiagnosisSettings) -> tuple[int, int | None]:
    """(IoU thresholds, score thresholds or None without a sweep) of these settings."""
    return len(settings.limits), None if settings.sweep is None else len(settings.sweep.labels)


def diagnosis_part(settings: DiagnosisSettings | None, diagnoses: FrameDiagnoses | None,
                   n_entries: int) -> dict[str, np.ndarray]:
    """A shard's diagnoses as its part keeps them (none without settings): frame-first arrays whose
    rows the merge concatenates in shard order (`cat_`), empty for a shard without frames."""
    if settings is None:
        return {}
    n_limits, n_scores = _sizes(settings)
    if diagnoses is None:
        diagnoses = FrameDiagnoses((), np.zeros(0, np.int64), np.zeros((n_entries, 0), np.int64),
                                   np.zeros((n_entries, 0, n_limits), np.int64),
                                   np.zeros((n_entries, 0, n_limits, len(ERROR_TYPES)), np.int64),
                                   None if n_scores is None else np.zeros((n_entries, 0, n_scores, n_limits), np.int64),
                                   None if n_scores is None else np.zeros((n_entries, 0, n_scores), np.int64))
    arrays = {"cat_diag_n_gt": diagnoses.n_gt, "cat_diag_n_pred": diagnoses.n_pred.T,
              "cat_diag_tp": diagnoses.tp.transpose(1, 0, 2), "cat_diag_errors": diagnoses.errors.transpose(1, 0, 2, 3)}
    if n_scores is not None:
        assert diagnoses.sweep_tp is not None and diagnoses.sweep_kept is not None
        arrays.update(cat_diag_sweep_tp=diagnoses.sweep_tp.transpose(1, 0, 2, 3),
                      cat_diag_sweep_kept=diagnoses.sweep_kept.transpose(1, 0, 2))
    return {name: np.ascontiguousarray(array, np.int64) for name, array in arrays.items()}


def diagnoses_merged(settings: DiagnosisSettings | None, frames: Sequence[str], merged_array: Callable[..., np.ndarray],
                     n_entries: int) -> FrameDiagnoses | None:
    """The diagnoses of a merge whose shards were scored with these settings (None without), from
    their parts' arrays (`merged_array(name, shape, kind, within)` checks each shape and range:
    an untrusted file)."""
    if settings is None:
        return None
    n_limits, n_scores = _sizes(settings)
    n = len(frames)

    def read(name: str, *shape: int) -> np.ndarray:
        return merged_array(f"cat_diag_{name}", (n, *shape), "i", (0, 1 << 40))

    tp = read("tp", n_entries, n_limits).transpose(1, 0, 2)
    n_gt, n_pred = read("n_gt"), read("n_pred", n_entries).T
    errors = read("errors", n_entries, n_limits, len(ERROR_TYPES)).transpose(1, 0, 2, 3)
    if (tp > n_gt[None, :, None]).any() or (tp > n_pred[:, :, None]).any() or (
            errors.sum(axis=3) > (n_gt[None, :, None] + n_pred[:, :, None])).any():
        raise ValueError("the parts' error types exceed their lanes")
    sweep_tp = sweep_kept = None
    if n_scores is not None:
        sweep_tp = read("sweep_tp", n_entries, n_scores, n_limits).transpose(1, 0, 2, 3)
        sweep_kept = read("sweep_kept", n_entries, n_scores).transpose(1, 0, 2)
    return FrameDiagnoses(tuple(frames), n_gt, n_pred, tp, errors, sweep_tp, sweep_kept)


def _joined(arrays: Sequence[np.ndarray | None]) -> np.ndarray:
    return np.concatenate([array for array in arrays if array is not None], axis=1)


def error_records(diagnoses: FrameDiagnoses, entries: Sequence[tuple[str, str]],
                  groups: Sequence[tuple[str, np.ndarray]], labels: Sequence[str], types: Sequence[int],
                  measure: Measure = f_measure) -> list[tuple]:
    """errors.csv's rows (method, matching, category, threshold, side, type, count, dF1): per entry
    of the method axis (its method and matching), category group (name, frame mask) and
    threshold, the count and dF1 of each error type of `types` (indices into ERROR_TYPES)."""
    rows = []
    for m, (method, matching) in enumerate(entries):
        for name, inside in groups:
            n_gt = int(diagnoses.n_gt[inside].sum())
            n_pred = int(diagnoses.n_pred[m, inside].sum())
            tps = diagnoses.tp[m, inside].sum(axis=0)
            counts = diagnoses.errors[m, inside].sum(axis=0)
            for t, label in enumerate(labels):
                tp = int(tps[t])
                deltas = delta_f1(tp, n_pred - tp, n_gt - tp, counts[t].tolist(), measure)
                for k in types:
                    side, kind = ERROR_TYPES[k]
                    rows.append((method, matching, name, label, side, kind, int(counts[t, k]), float(deltas[k])))
    return rows


def sweep_records(diagnoses: FrameDiagnoses, entries: Sequence[tuple[str, str]],
                  groups: Sequence[tuple[str, np.ndarray]], labels: Sequence[str], sweep: ScoreSweep,
                  measure: Measure = f_measure) -> list[tuple]:
    """sweep_scores.csv's rows (method, matching, category, threshold, score_threshold, tp, fp, fn,
    precision, recall, f1, best): per entry, category group and IoU threshold, at each score
    threshold; `best` marks the highest F1 (the lowest score threshold of equal ones), chosen on
    the frames scored."""
    assert diagnoses.sweep_tp is not None and diagnoses.sweep_kept is not None
    rows = []
    for m, (method, matching) in enumerate(entries):
        for name, inside in groups:
            n_gt = int(diagnoses.n_gt[inside].sum())
            kept = diagnoses.sweep_kept[m, inside].sum(axis=0)
            tps = diagnoses.sweep_tp[m, inside].sum(axis=0)
            for t, label in enumerate(labels):
                block = []
                for c, score in enumerate(sweep.labels):
                    tp, n_pred = int(tps[c, t]), int(kept[c])
                    block.append((method, matching, name, label, score, tp, n_pred - tp, n_gt - tp,
                                  *measure(tp, n_pred - tp, n_gt - tp)))
                f1s = [-np.inf if np.isnan(row[-1]) else row[-1] for row in block]
                best = int(np.argmax(f1s)) if max(f1s, default=-np.inf) > -np.inf else -1  # the first of equal ones
                rows += [(*row, c == best) for c, row in enumerate(block)]
    return rows
