"""An official lane metric as a torchmetrics `Metric` (Lightning logs it as it is): its state is
the per-frame records, gathered across processes by concatenation (`dist_reduce_fx="cat"`) and
combined at `compute()` as one process would (a frame given twice with the same lanes, as a
distributed sampler pads, is kept once).

    from roneld_eval.frameworks.torchmetrics_metric import LaneMetric
    self.val_lanes = LaneMetric("culane", data_root="data/culane", preset="clrnet")
    self.val_lanes.update(frames, lanes)            # in validation_step
    self.log_dict(self.val_lanes.compute())         # in on_validation_epoch_end; then .reset()

A record travels as bytes in a uint8 tensor (torch.distributed gathers tensors only): its length,
then its pickle. The bytes come from this job's own processes, as mmengine's and torch's
all_gather_object pickles do.
"""

from __future__ import annotations

import pickle
from typing import Any, Sequence

import numpy as np
import torch
from torchmetrics import Metric

from ..in_memory import MetricInputError, kept_once, metric

_LENGTH = np.dtype("<u8")


def pack(record: tuple[str, Any]) -> torch.Tensor:
    body = pickle.dumps(record, protocol=pickle.HIGHEST_PROTOCOL)
    return torch.from_numpy(np.frombuffer(np.array([len(body)], _LENGTH).tobytes() + body, np.uint8).copy())


def unpack(data: torch.Tensor) -> list[tuple[str, Any]]:
    """Records from their packed bytes, however the tensors holding them were concatenated."""
    raw = data.cpu().numpy().astype(np.uint8).tobytes()
    out, at = [], 0
    while at < len(raw):
        if at + _LENGTH.itemsize > len(raw):
            raise MetricInputError("a lane metric's gathered state is cut short")
        size = int(np.frombuffer(raw, _LENGTH, 1, at)[0])
        at += _LENGTH.itemsize
        if at + size > len(raw):
            raise MetricInputError("a lane metric's gathered state is cut short")
        out.append(pickle.loads(raw[at:at + size]))
        at += size
    return out


class LaneMetric(Metric):
    """`benchmark` and its options as `roneld_eval.metric(benchmark, **options)` takes them.
    `update(frames, lanes, scores=None)`: a batch, as `Metric.update_many`; `compute()`: the
    metric's dict of floats (`names`: another framework's key names where offered)."""

    full_state_update = False
    is_differentiable = False
    higher_is_better = True

    def __init__(self, benchmark: str, names: str | None = None, **options: Any):
        super().__init__()
        self.lane_metric = metric(benchmark, **options)
        self.lane_metric.check_names(names)
        self.names = names
        self.add_state("records", default=[], dist_reduce_fx="cat")
        self._given: dict[str, Any] = {}  # this process's frames since reset: a clash refused at update

    def update(self, frames: Sequence[str], lanes: Sequence[Any], scores: Sequence[Any] | None = None,
               **fields: Sequence[Any]) -> None:
        """A batch: `lanes[k]` (and `scores[k]`, and each field's k-th value, as `categories=` for
        OpenLane or `run_time=` for TuSimple) is frame k's. All taken, or (one refused) none."""
        frames, lanes = list(frames), list(lanes)
        given: dict[str, Sequence[Any] | None] = {"scores": scores, **fields}
        columns = {key: list(value) for key, value in given.items() if value is not None}
        if any(len(value) != len(frames) for value in (lanes, *columns.values())):
            raise MetricInputError(f"update: {len(frames)} frames, {len(lanes)} lane lists"
                                   + "".join(f", {len(v)} {key}" for key, v in columns.items())
                                   + ": one of each per frame")
        score_column = columns.pop("scores", None)
        records = [self.lane_metric.record(frame, lanes[k], None if score_column is None else score_column[k],
                                           **{key: value[k] for key, value in columns.items()})
                   for k, frame in enumerate(frames)]
        fresh = kept_once(records, self._given, "given twice with different lanes (reset() starts again)")
        self._given.update(fresh)
        self.records.extend(pack(record) for record in fresh.items())

    def forward(self, *args: Any, **kwargs: Any) -> None:
        """An update: an official metric has no score of one batch (the frames not yet given
        would count as missed), so `metric(frames, lanes)` returns nothing; `compute()` scores."""
        self.update(*args, **kwargs)

    def reset(self) -> None:
        super().reset()
        self._given = {}

    def compute(self) -> dict[str, float]:
        state = self.records
        if isinstance(state, torch.Tensor):  # after a sync: one concatenated tensor
            state = [state]
        return self.lane_metric.compute_records((record for data in state for record in unpack(data)), self.names)
