"""VIL-100's official metrics in memory (`roneld_eval.metric("vil100", labels=..., sizes_file=...)`):
each frame matched as `score vil100` matches it (MMA-Net's F1 and mIoU, RVLD's Acc/FP/FN and the
assigned IoUs its temporal metrics need), the sequences summed as its tables sum them. Lanes are
(N, 2) arrays of image pixels, as a `.lines.txt` lists them; MMA-Net's instance masks are scored
from files only (`score vil100 --pred-format png`)."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Sequence

from ...in_memory import TruthMemo, pixel_lanes
from ...metrics.lane_iou_f1 import highlight_name
from ...scoring import PlainTable
from ...thresholds import parse_thresholds
from .reader import read_vil100
from .score import (ACC_COLUMNS, COLUMNS, DEFAULT_IOU, LANE_WIDTH, TEMPORAL_COLUMNS, FrameOutcome, FrameTruth,
                    ScoredSequence, Vil100Score, acc_rows, frame_outcome, frame_truth, official_rows, sequence_totals,
                    summary_rows, temporal_rows)
from .temporal import links

VERSIONS = ("rvld",)  # MMA-Net's Acc reads instance masks, which lanes in memory are not


class Vil100Metric:
    """`F1@50`, `F1@80`, `mIoU` (the first threshold's sequences), `Rs@50`, `Rj@50`, `Rm@50` (each
    threshold as tau), `Acc`, `FP`, `FN` (RVLD's), over every sequence; a scenario's after its name
    (`curved-road/F1@50`)."""

    name = "vil100"

    def __init__(self, labels: str | Path, list_file: str | Path | None = None, image_root: str | Path | None = None,
                 json_root: str | Path | None = None, sizes_file: str | Path | None = None,
                 iou: str | None = None, width: int = LANE_WIDTH, temporal: bool = True):
        from ...config import check_lane_width

        check_lane_width(width)
        self.thresholds = parse_thresholds(iou or DEFAULT_IOU)
        self.width, self.temporal = width, temporal
        self.dataset = read_vil100(labels, list_file, image_root, json_root, sizes_file)
        self.frames = tuple(relpath for frames in self.dataset.sequences.values() for relpath in frames)
        self._sequence = {relpath: name for name, frames in self.dataset.sequences.items() for relpath in frames}
        self.truth = TruthMemo(self._drawn_truth)
        self._links: dict[str, list[list[tuple[int, int]]]] = {}

    def _drawn_truth(self, frame: str) -> FrameTruth:
        width, height = self.dataset.sizes[self._sequence[frame]]
        return frame_truth(self.dataset.labels, frame, width, height, self.width, self.temporal)

    def frame_counts(self, frame: str, lanes: Any, scores: Any = None) -> FrameOutcome:
        """The frame's outcome (`scores` are not read: VIL-100's metrics count every lane)."""
        width, height = self.dataset.sizes[self._sequence[frame]]
        return frame_outcome(self.truth(frame), pixel_lanes(lanes), width, height, self.width, self.temporal)

    def _sequence_links(self, name: str) -> list[list[tuple[int, int]]]:
        """The ground truth's lanes linked across the sequence's consecutive frames (truth only)."""
        if name not in self._links:
            found: list[list[tuple[int, int]]] = []
            previous = None
            for relpath in self.dataset.sequences[name]:
                linked = self.truth(relpath).linked
                found.append([] if previous is None else links(linked, previous))
                previous = linked
            self._links[name] = found
        return self._links[name]

    def _outcome(self, frame: str, given: FrameOutcome | None) -> FrameOutcome:
        return self.frame_counts(frame, []) if given is None else given

    def _score(self, counts: Sequence[FrameOutcome | None]) -> Vil100Score:
        by_frame = dict(zip(self.frames, counts))
        totals = []
        for name, relpaths in self.dataset.sequences.items():
            outcomes = [self._outcome(r, by_frame[r]) for r in relpaths]
            piece = ScoredSequence([[(o.matches, o.miou) for o in outcomes]],
                                   self._sequence_links(name) if self.temporal else [],
                                   [[o.assigned for o in outcomes]], [[(o.acc, None) for o in outcomes]],
                                   [r for r in relpaths if self.truth(r).outside], [[]])
            totals.append(sequence_totals(piece, relpaths, self.thresholds, self.temporal, VERSIONS))
        names, methods = list(self.dataset.sequences), ("-",)
        rows, overall = official_rows(names, methods, totals, self.thresholds)
        temporal, temporal_overall = (temporal_rows(names, methods, totals, self.thresholds) if self.temporal
                                      else ([], {}))
        acc, acc_overall = acc_rows(names, methods, totals, VERSIONS)
        return Vil100Score(PlainTable(COLUMNS, tuple(rows)),
                           PlainTable(TEMPORAL_COLUMNS, tuple(temporal)) if self.temporal else None,
                           self.thresholds, methods, len(self.frames), len(names), overall, temporal_overall,
                           PlainTable(ACC_COLUMNS, tuple(acc)), acc_overall)

    def tables(self, counts: Sequence[FrameOutcome | None]) -> dict[str, PlainTable]:
        """official.csv's, temporal.csv's, acc.csv's and summary.csv's rows as `score vil100`
        writes them (method '-'); frames never updated have no lanes, as a missing file."""
        score = self._score(counts)
        out = {"official": score.rows}
        if score.temporal_rows is not None:
            out["temporal"] = score.temporal_rows
        assert score.acc_rows is not None
        out.update(acc=score.acc_rows, summary=summary_rows(score))
        return out

    def compute(self, counts: Sequence[FrameOutcome | None]) -> dict[str, float]:
        tables = self.tables(counts)
        out: dict[str, float] = {}
        first = self.thresholds.labels[0]
        for _, category, label, _, _, _, precision, recall, f1, miou, _ in tables["official"].rows:
            prefix = _prefix(category)
            if prefix is None:
                continue
            percent = highlight_name(label)[len("F1@"):]
            out.update({f"{prefix}F1@{percent}": float(f1), f"{prefix}precision@{percent}": float(precision),
                        f"{prefix}recall@{percent}": float(recall)})
            if label == first:
                out[f"{prefix}mIoU"] = float(miou)
        for _, category, label, _, _, _, _, rs, rj, rm in tables.get("temporal", PlainTable((), ())).rows:
            prefix = _prefix(category)
            if prefix is not None:
                percent = highlight_name(label)[len("F1@"):]
                out.update({f"{prefix}Rs@{percent}": float(rs), f"{prefix}Rj@{percent}": float(rj),
                            f"{prefix}Rm@{percent}": float(rm)})
        for _, category, _, _, accuracy, fp, fn, _ in tables["acc"].rows:
            prefix = _prefix(category)
            if prefix is not None:
                out.update({f"{prefix}Acc": float(accuracy), f"{prefix}FP": float(fp), f"{prefix}FN": float(fn)})
        return out


def _prefix(category: str) -> str | None:
    """'' for every sequence, 'curved-road/' for scenario 2 (curved road); None for one sequence's
    row (a training loop logs the totals and the scenarios papers print, not 100 sequences)."""
    if category == "all":
        return ""
    if category.startswith("scenario ") and category.endswith(")"):
        return category[category.index("(") + 1:-1].replace(" ", "-") + "/"
    return None
