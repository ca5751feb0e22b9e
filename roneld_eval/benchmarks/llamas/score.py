"""`score llamas`: predicted `.lines.txt` files scored as LLAMAS's culane_metric/evaluate.py scores
them (karstenBehrendt/unsupervised_llamas 9b99f46: datasets.llamas for the labels,
official.py for the metric), every method and threshold in one pass over the labels.
Papers print F1 at IoU 0.5 (the script's), at 0.75, and mF1 as CLRNet computes it
(Turoad/CLRNet 7269e9d, clrnet/utils/llamas_metric.py:230-244 with the thresholds of
clrnet/datasets/llamas.py:178): F1 / 10 added up over np.linspace(0.5, 0.95, 10), whose ninth
value is 0.8999999999999999; it is always scored, whatever --iou asks.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass, replace
from functools import partial
from operator import itemgetter
from pathlib import Path
from typing import Any, Callable, Collection, Iterable, NamedTuple

import numpy as np

from ...config import check_lane_width
from .reader import (IMAGE_HEIGHT, IMAGE_WIDTH, every_label, label_of, map_path, marker_lanes,
                               prediction_path, read_record)
from ...errors import ConfigError, InputError
from ...lanes_io import check_coordinates, read_lines_txt
from ...maps.scnn_png import read_grey_png
from .official import counts_at, f1_of, frame_counts, interpolated, iou_matrix, lane_mask, matched_lanes
from .segmentation import CLASSES, IMAGE_HEIGHT as MAP_HEIGHT, IMAGE_WIDTH as MAP_WIDTH, approx_auc
from .segmentation import class_masks, mean_curves, ClassCurve
from ...metrics.lane_errors import (DiagnosisCollector, DiagnosisSettings, FrameDiagnoses, diagnosis_part,
                                    diagnosis_settings, diagnoses_merged, joined_diagnoses, kernel_groups)
from ...output import Staging
from ...metrics.lane_iou_f1 import highlighted
from ...report.diagnosis import Diagnosed, write_diagnosis
from ...report.gallery import GalleryFrame
from ...report.tables import Table
from ...scoring import (PlainTable, PredictionRoots, _taking, find_prediction_trees, only_frames, percent,
                        scored_pieces)
from ...shards import Merged, Sharding, given_options
from ...thresholds import Thresholds, parse_thresholds

DEFAULT_IOU = "0.50:0.95:0.05"  # mF1's grid; 0.5 is the script's own threshold
LANE_WIDTH = 30  # evaluate.py --width default
COLUMNS = ("method", "threshold", "tp", "fp", "fn", "precision", "recall", "f1")
AP_COLUMNS = ("ap_l1", "ap_l0", "ap_r0", "ap_r1", "ap_mean")
CHUNK_FRAMES = 200
MF1_THRESHOLDS = tuple(np.linspace(0.5, 0.95, 10).tolist())


@dataclass(frozen=True)
class LlamasScore:
    rows: PlainTable
    thresholds: Thresholds
    methods: tuple[str, ...]
    n_frames: int
    stopping: dict  # where the script stops: "labels" (lanes add_ys refuses), per method "lanes" splprep refuses
    mf1s: dict  # method -> CLRNet's mF1
    warnings: tuple[str, ...] = ()
    # method -> per class l1, l0, r0, r1 the mean ClassCurve (recall, precision, threshold, AUC) of
    # its probability maps, as evaluate_segmentation.py prints them; methods given maps only
    segmentation: dict = dataclasses.field(default_factory=dict)
    diagnosed: Diagnosed | None = None  # --diagnose: the lane files' error types and every frame's counts

    def ap(self, method: str, name: str) -> float:
        """AP of a class (l1, l0, r0, r1), or 'mean' over the four; NaN for a method without maps."""
        return _ap_values(self.segmentation.get(method))[(*CLASSES, "mean").index(name)]

    def f1(self, method: str, label: str) -> float:
        """F1 at a threshold; NaN for a method given maps only."""
        return next((row[7] for row in self.rows.rows if row[0] == method and row[1] == label), math.nan)

    def mf1(self, method: str) -> float:
        return self.mf1s.get(method, math.nan)


def _ap_values(curves) -> tuple[float, ...]:
    """AP of l1, l0, r0, r1 and their mean (ours: the script prints the classes); NaN without maps."""
    if curves is None:
        return (math.nan,) * (len(CLASSES) + 1)
    aps = tuple(curve.auc for curve in curves)
    return (*aps, sum(aps) / len(aps))


def _predicted(path: Path, width: int) -> tuple[list, int]:
    """load_prediction then interpolate_lane: masks of the lanes of two points or more, and how
    many of them splprep refuses (where the script stops; here they are left out)."""
    lanes = read_lines_txt(path)  # a missing file: no lanes (the script stops: FileNotFoundError)
    check_coordinates(lanes, path)  # as every reader of predicted lanes: 1e308 overflowed the drawing
    return predicted_masks(lanes, width)


def predicted_masks(lanes, width: int) -> tuple[list, int]:
    """interpolate_lane and the drawing of each lane of two points or more, and how many splprep refuses."""
    masks, refused = [], 0
    for lane in lanes:
        if len(lane.points) < 2:
            continue
        samples = interpolated(lane)
        if samples is None:
            refused += 1
            continue
        masks.append(lane_mask(samples, IMAGE_WIDTH, IMAGE_HEIGHT, width))
    return masks, refused


def _class_curves(root: Path, key: str, masks: np.ndarray) -> list[ClassCurve]:
    """single_threaded_multi_eval_single_image for classes 1..4: each map against its class."""
    curves = []
    for c, truth in enumerate(masks, start=1):
        path = map_path(root, key, c)
        values = read_grey_png(path)  # the script stops on a missing map (imread gives None)
        if values.shape != (MAP_HEIGHT, MAP_WIDTH):
            raise InputError(path, f"a {values.shape[1]}x{values.shape[0]} map: LLAMAS's labels are "
                                   f"{MAP_WIDTH}x{MAP_HEIGHT}")
        curves.append(approx_auc(values, truth))
    return curves


def _segmentation_label(record, path: Path) -> np.ndarray:
    projection, lanes = marker_lanes(record, path)
    try:
        return class_masks(projection, lanes)
    except KeyError as missing:  # dataset_constants.DICT_COLORS has l0..l7 and r0..r8 only
        raise InputError(path, f"lane {missing} has no colour in LLAMAS's segmentation labels "
                               "(l0..l7, r0..r8), where evaluate_segmentation.py stops") from None


def truth_masks(label, width: int) -> list:
    """The label's lanes drawn as evaluate.py draws them."""
    return [lane_mask(lane.points, IMAGE_WIDTH, IMAGE_HEIGHT, width) for lane in label.lanes]


def _score_frames(args):
    keys, labels, pred_roots, thresholds, width, map_roots, diagnosis = args
    counts = np.zeros((len(pred_roots), len(thresholds), 3), np.int64)
    dropped, refused = 0, np.zeros(len(pred_roots), np.int64)
    curves: list[list[list[ClassCurve]]] = [[] for _ in map_roots]  # per method, per frame, per class
    diagnosed = DiagnosisCollector(diagnosis, len(pred_roots))
    for key in keys:
        record = read_record(labels[key])
        if pred_roots:
            label = label_of(record, labels[key])
            dropped += label.dropped_above
            truth = truth_masks(label, width)
            for m, root in enumerate(pred_roots):
                predicted, stopped = _predicted(prediction_path(root, key), width)
                refused[m] += stopped
                counts[m] += _method_frame(truth, predicted, thresholds, diagnosed, m)
        if map_roots:
            masks = _segmentation_label(record, labels[key])
            for m, root in enumerate(map_roots):
                curves[m].append(_class_curves(root, key, masks))
    return counts, dropped, refused, curves, diagnosed.result(keys if pred_roots else [])


def _method_frame(truth: list, predicted: list, thresholds, diagnosed: DiagnosisCollector, m: int) -> np.ndarray:
    """frame_counts of a method's frame; when diagnosing, its IoUs (computed once) give its error
    types too, under evaluate.py's own assignment (linear_sum_assignment)."""
    if diagnosed.settings is None:
        return frame_counts(truth, predicted, thresholds)
    ious = iou_matrix(predicted, truth)
    errors = diagnosed.add(m, partial(np.transpose, ious), match=matched_lanes(ious))
    assert errors is not None  # its matched IoUs: matched_ious' pairs (-inf for a lane unmatched, above no threshold)
    return counts_at(errors.matched_iou, len(predicted), len(truth), thresholds)


def _recording(key: str) -> str:
    return key.split("/")[0]  # a recording is a clip


def score_llamas(labels: str | Path, pred_root: PredictionRoots = (), iou: str | None = None,
                 width: int = LANE_WIDTH, out: str | Path | None = None, workers: int | None = None,
                 progress: bool = False, announce: Callable[[str], None] | None = None, strict: bool = False,
                 maps: PredictionRoots = (), shard: str | None = None,
                 merged: Merged | None = None, diagnose: bool = False,
                 loc_iou: float | None = None, frames: Collection[str] | None = None) -> LlamasScore | None:
    """Score `.lines.txt` predictions (`<recording>/<frame>.lines.txt`, `pred_root`) for F1 and
    probability maps (`<recording>/<frame>.json_<c>.png`, `maps`) for AP against every label below
    `labels` (one split's folder of `<recording>/<frame>.json`). With `shard` ('I/N'), only that
    share of the recordings, written as a part to `out` (None is returned). `diagnose`: the lane
    files' error types and every frame's counts, as `score culane --diagnose` gives them."""
    thresholds = parse_thresholds(iou or DEFAULT_IOU)
    diagnosis = _diagnosis(diagnose, loc_iou, thresholds, shard, pred_root)
    check_lane_width(width)
    if not _given(pred_root) and not _given(maps):
        raise ConfigError("nothing to score: give --pred-root (lane files, for F1) or --maps (probability "
                          "maps, for AP), or both")
    sharding = Sharding("score llamas", shard, out, merged, dict(
        labels=labels, pred_root=pred_root, iou=iou, width=width, strict=strict, maps=maps,
        **given_options(diagnose=diagnose, loc_iou=loc_iou)))
    with _taking(out, "score llamas", reads=(labels,)) as folder:
        found = _labels(Path(labels), frames, shard)
        keys = list(found)
        trees, warnings, map_trees = _methods(pred_root, maps, keys, strict, announce)
        scored_at = tuple(thresholds.values) + MF1_THRESHOLDS
        files_of = _files_of(trees, map_trees)
        if merged is not None:
            sharding.check_merged(keys, [*trees, *map_trees], list(found.values()), _recording, files_of=files_of)
            totals = _merged_totals(sharding, diagnosis, keys, len(trees), len(map_trees), len(scored_at))
        else:
            scored = sharding.share(keys, _recording)
            chunks = [scored[i:i + CHUNK_FRAMES] for i in range(0, len(scored), CHUNK_FRAMES)]
            tasks = [(chunk, {key: found[key] for key in chunk}, tuple(tree.root for tree in trees), scored_at, width,
                      tuple(tree.root for tree in map_trees), diagnosis) for chunk in chunks]
            pieces = scored_pieces(_score_frames, tasks, workers, progress, announce,
                                   kernel_groups=kernel_groups((), diagnosis), trees=[*trees, *map_trees])
            totals = _summed_totals(pieces, len(trees), len(map_trees), len(scored_at))
            if sharding.shard is not None:
                assert folder is not None
                sharding.write_part(folder, keys, [*trees, *map_trees], list(found.values()), scored, {
                    "sum_counts": totals.counts, "sum_dropped": np.array([totals.dropped], np.int64),
                    "sum_refused": totals.refused, "cat_curves": totals.curves,
                    **diagnosis_part(diagnosis, totals.diagnoses, len(trees))}, files_of=files_of)
                return None
        diagnoses = totals.diagnoses
        segmentation = _segmentation(map_trees, totals.curves)
        rows, mf1s, methods = _official_rows(trees, map_trees, thresholds, totals.counts, segmentation)
        stopping = {"labels": totals.dropped, **{tree.method: int(totals.refused[m]) for m, tree in enumerate(trees)}}
        warnings += _stopping_warnings(trees, stopping)
        score = LlamasScore(PlainTable(COLUMNS + AP_COLUMNS, rows), thresholds, methods, len(keys), stopping,
                            mf1s, tuple(warnings), segmentation)
        score = _diagnosed(score, diagnoses, trees, width, diagnosis, found)
        if folder is not None:
            staging = Staging(folder)
            staging.write_text("official.csv", score.rows.to_csv())
            staging.write_text("summary.csv", summary_rows(score).to_csv())
            staging.write_text("summary.md", summary_markdown(score, width))
            write_diagnosis(staging, score.diagnosed, highlighted(thresholds.labels))
            folder.commit()
    return score


def _methods(pred_root: PredictionRoots, maps: PredictionRoots, keys: list[str], strict: bool, announce):
    """(the lane-file trees, their warnings, the map trees): what is given of each."""
    trees, warnings = (find_prediction_trees(pred_root, keys, strict, announce, suffix=".lines.txt")
                       if _given(pred_root) else ([], []))
    return trees, warnings, (_map_trees(maps, keys, announce) if _given(maps) else [])


class _Totals(NamedTuple):
    """What the frames reduce to: F1 counts (method, threshold, TP/FP/FN), labelled lanes dropped
    and predicted lanes refused where evaluate.py stops, each frame's AP curves (frames, map
    methods, classes, recall/precision/threshold/AUC) in key order, and the error types."""

    counts: np.ndarray
    dropped: int
    refused: np.ndarray
    curves: np.ndarray
    diagnoses: FrameDiagnoses | None


def _summed_totals(pieces, n_trees: int, n_maps: int, n_scored_at: int) -> _Totals:
    per_frame = [[[(c.recall, c.precision, c.threshold, c.auc) for c in piece[3][m][f]] for m in range(n_maps)]
                 for piece in pieces for f in range(len(piece[3][0]) if n_maps else 0)]
    return _Totals(
        counts=sum((piece[0] for piece in pieces), np.zeros((n_trees, n_scored_at, 3), np.int64)),
        dropped=int(sum(piece[1] for piece in pieces)),
        refused=sum((piece[2] for piece in pieces), np.zeros(n_trees, np.int64)),
        curves=np.array(per_frame, np.float64).reshape(len(per_frame), n_maps, len(CLASSES), 4),
        diagnoses=joined_diagnoses(map(itemgetter(4), pieces)))


def _merged_totals(sharding: Sharding, diagnosis, keys: list[str], n_trees: int, n_maps: int,
                   n_scored_at: int) -> _Totals:
    return _Totals(
        counts=sharding.merged_array("sum_counts", (n_trees, n_scored_at, 3)),
        dropped=int(sharding.merged_array("sum_dropped", (1,))[0]),
        refused=sharding.merged_array("sum_refused", (n_trees,)),
        curves=sharding.merged_array("cat_curves", (len(keys) if n_maps else 0, n_maps, len(CLASSES), 4), kind="f",
                                     within=(0.0, 1.0)),
        diagnoses=diagnoses_merged(diagnosis, keys, sharding.merged_array, n_trees))


def _segmentation(map_trees, curves: np.ndarray) -> dict[str, tuple]:
    """Each map method's mean curve a class, the frames in key order: summed as evaluate_set sums it."""
    return {tree.method: tuple(mean_curves([ClassCurve(*(float(v) for v in curves[f, m, c]))
                                            for f in range(len(curves))]) for c in range(len(CLASSES)))
            for m, tree in enumerate(map_trees)}


def _official_rows(trees, map_trees, thresholds: Thresholds, counts: np.ndarray,
                   segmentation: dict[str, tuple]) -> tuple[tuple, dict[str, Any], tuple[str, ...]]:
    """official.csv's rows (a lane-file method's F1 a threshold, with its maps' AP where it has
    them; a maps-only method one row of AP), each lane-file method's mF1, and the methods."""
    rows, mf1s = [], {}
    for m, tree in enumerate(trees):
        ap = _ap_values(segmentation.get(tree.method))
        for t, label in enumerate(thresholds.labels):
            tp, fp, fn = (int(v) for v in counts[m, t])
            rows.append((tree.method, label, tp, fp, fn, *f1_of(tp, fp, fn), *ap))
        mf1s[tree.method] = clrnet_mf1(counts[m, len(thresholds.values):])
    methods = tuple(dict.fromkeys([tree.method for tree in trees] + [tree.method for tree in map_trees]))
    for method in methods:
        if method not in mf1s:
            rows.append((method, "", None, None, None, math.nan, math.nan, math.nan, *_ap_values(segmentation[method])))
    return tuple(rows), mf1s, methods


def _stopping_warnings(trees, stopping: dict[str, int]) -> list[str]:
    """What evaluate.py would stop on, left out instead: said, never silently."""
    warnings = []
    if stopping["labels"]:
        warnings.append(f"warning: {stopping['labels']} labelled lanes have their valid points above row 300 only, "
                        "where evaluate.py stops (add_ys' assert): left out")
    for tree in trees:
        if stopping[tree.method]:
            warnings.append(f"warning: {tree.method}: {stopping[tree.method]} lanes that scipy's splprep "
                            "refuses, where evaluate.py stops: left out")
    return warnings


def _labels(labels: Path, frames: Collection[str] | None, shard: str | None) -> dict[str, Path]:
    """key -> label file of every label, or of `frames` alone (a run's own: run --diagnose)."""
    found = every_label(labels)
    return found if frames is None else {key: found[key] for key in only_frames(list(found), frames, shard)}


def _diagnosis(diagnose: bool, loc_iou: float | None, thresholds: Thresholds, shard: str | None,
               pred_root: PredictionRoots) -> DiagnosisSettings | None:
    diagnosis = diagnosis_settings(diagnose, loc_iou, None, thresholds.values)
    if diagnosis is not None and not _given(pred_root):
        raise ConfigError("--diagnose gives the error types of lane files: give --pred-root (maps are scored for "
                          "AP, which has no lanes to match)")
    return diagnosis


def _diagnosed(score: LlamasScore, diagnoses: FrameDiagnoses | None, trees: list, width: int,
               diagnosis: DiagnosisSettings | None, labels: dict) -> LlamasScore:
    """The score with its diagnosis: every frame in one group (`all`), its recording as its sequence;
    a frame's lanes read again for the gallery (its image: `<key>.png` under `show --image-root`)."""
    if diagnosis is None or diagnoses is None:
        return score

    def lanes_of(key: str) -> GalleryFrame:
        return GalleryFrame((IMAGE_WIDTH, IMAGE_HEIGHT), label_of(read_record(labels[key]), labels[key]).lanes,
                            {tree.method: read_lines_txt(prediction_path(tree.root, key)) for tree in trees},
                            f"{key}.png")

    return replace(score, diagnosed=Diagnosed(
        diagnoses, tuple((tree.method, "") for tree in trees), (("all", np.ones(len(diagnoses.frames), bool)),),
        score.thresholds.labels, diagnosis.loc_iou, lambda key: (_recording(key), ""),
        f"LLAMAS, evaluate.py's lane IoU F1 ({width} px at {IMAGE_WIDTH}x{IMAGE_HEIGHT})", errors=diagnosis.errors,
        frame_lanes=lanes_of))


def clrnet_mf1(counts) -> float:
    """CLRNet's mF1 from the (MF1_THRESHOLDS, 3) counts: llamas_metric.py's mean_f1 += f1 / 10."""
    mean = 0.0
    for tp, fp, fn in counts:
        mean += f1_of(int(tp), int(fp), int(fn))[2] / len(MF1_THRESHOLDS)
    return mean


def _given(roots: PredictionRoots) -> bool:
    return isinstance(roots, (str, Path)) or bool(roots)


def _files_of(trees: list, map_trees: list):
    """The files a frame is read from in each of the trees, then each of the map trees."""
    def files_of(m: int, key: str) -> list[Path]:
        if m < len(trees):
            return [prediction_path(trees[m].root, key)]
        return [map_path(map_trees[m - len(trees)].root, key, c) for c in range(1, len(CLASSES) + 1)]

    return files_of


def _map_trees(maps: PredictionRoots, keys: list[str], announce) -> list:
    """The probability-map trees, each holding every label's maps (evaluate_segmentation.py stops
    at the first missing one)."""
    trees, _ = find_prediction_trees(maps, keys, False, announce, suffix=".json_1.png", option="--maps")
    for tree in trees:
        if tree.found < tree.listed:
            first = next(map_path(tree.root, key, 1) for key in keys if not map_path(tree.root, key, 1).exists())
            raise InputError(tree.root, f"{tree.listed - tree.found:,} of {tree.listed:,} labels have no probability "
                                        f"maps (first: {first}); the AP needs every label's <frame>.json_1..4.png")
    return trees


def _headline(score: LlamasScore) -> list[tuple[str, str, Callable[[str], float]]]:
    """(printed name, summary.csv column, value of a method) of each headline number: F1 at 0.5 and
    0.75 and mF1 where lane files were scored, AP per class and its mean where maps were."""
    labels = dict(zip((round(v, 2) for v in score.thresholds.values), score.thresholds.labels))
    out: list[tuple[str, str, Callable[[str], float]]] = []
    if score.mf1s:
        for value in (0.5, 0.75):
            if value in labels:
                name = f"F1@{labels[value]}"
                out.append((name, name.lower(), functools.partial(score.f1, label=labels[value])))
        out.append(("mF1", "mf1", score.mf1))
    if score.segmentation:
        for name in (*CLASSES, "mean"):
            out.append((f"AP {name}", f"ap_{name}", functools.partial(score.ap, name=name)))
    return out


def summary_rows(score: LlamasScore) -> PlainTable:
    heads = _headline(score)
    columns = ("method", *(column for _, column, _ in heads))
    return PlainTable(columns, tuple((method, *(f(method) for _, _, f in heads)) for method in score.methods))


def summary_table(score: LlamasScore) -> Table:
    """summary.csv in percent, as papers print it."""
    heads = [name for name, _, _ in _headline(score)]
    rows = tuple((row[0], *(percent(value) for value in row[1:])) for row in summary_rows(score).rows)
    return Table(("method", *(f"{name} (%)" for name in heads)), rows)


def summary_markdown(score: LlamasScore, width: int) -> str:
    return (f"# LLAMAS, official protocol\n\n{score.n_frames:,} labels on a {IMAGE_WIDTH}x{IMAGE_HEIGHT} canvas, lanes "
            f"{width} px wide, a match counts when IoU > the threshold (unsupervised_llamas "
            "culane_metric/evaluate.py, 9b99f46, its official discrete IoU): the labels' four lanes l1, l0, r0, r1 "
            "from its spline_creator over rows 300..716, predictions through splprep at 50 samples. mF1: CLRNet's "
            "(llamas_metric.py, 7269e9d), F1 / 10 summed over np.linspace(0.5, 0.95, 10). official.csv gives every "
            "threshold.\n\n"
            + (AP_NOTE if score.segmentation else "")
            + summary_table(score).to_markdown())


AP_NOTE = ("AP: the probability maps <frame>.json_<c>.png of classes l1, l0, r0, r1 against the label's markers "
           "drawn per class, over 101 thresholds, averaged over the labels (unsupervised_llamas "
           "evaluation/evaluate_segmentation.py --multi_class, 9b99f46); 'AP mean' is the mean of the four "
           "classes (ours: the script prints each class).\n\n")


def diagnose_run(lanes: Path, dataset, frames: Iterable[str], config, loc_iou: float | None,
                 announce: Callable[[str], None] | None = None) -> Diagnosed:
    """`run --diagnose`: the lanes the run saved (`lanes`) scored as `score llamas --diagnose`
    scores them, at the run's thresholds and lane width, over the frames it scored (`frames`)."""
    from .benchmark import THRESHOLDS
    from .reader import frame_key

    score = score_llamas(dataset.root, lanes, iou=THRESHOLDS, width=config.official.lane_width_px,
                         workers=config.workers, announce=announce, diagnose=True, loc_iou=loc_iou,
                         frames=[frame_key(frame) for frame in frames])
    assert score is not None and score.diagnosed is not None
    return score.diagnosed
