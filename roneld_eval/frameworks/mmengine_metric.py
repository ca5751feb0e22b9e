"""An official lane metric as an mmengine metric: each rank counts its frames in `process`
(nothing written), `compute_metrics` combines every rank's per-frame counts as one process
would (a frame a sampler padded in twice is kept once).

    custom_imports = dict(imports=["roneld_eval.frameworks.mmengine_metric"], allow_failed_imports=False)
    val_evaluator = dict(type="RoneldLaneMetric", benchmark="culane", data_root="data/culane",
                         iou="0.1,0.5,0.75", names="clrernet",
                         sample=dict(style="clrernet", width=1640, height=590))

Registered in mmengine's root METRICS, which the registries of mmdet, mmseg and the other
OpenMMLab libraries look up through.
"""

from __future__ import annotations

from typing import Any, Sequence

from mmengine.evaluator import BaseMetric
from mmengine.registry import METRICS

from ..in_memory import MetricInputError, metric
from .samples import sample_reader


@METRICS.register_module()
class RoneldLaneMetric(BaseMetric):
    """`benchmark` and its options as `roneld_eval.metric(benchmark, **options)` takes them;
    `names`: another framework's key names where the benchmark offers them ("clrernet" for
    CULane); `sample`: how a data sample holds its frame and lanes (samples.sample_reader)."""

    default_prefix = ""  # the keys as the metric names them (mmengine warns when None)

    def __init__(self, benchmark: str, sample: Any = "plain", names: str | None = None, prefix: str | None = None,
                 **options: Any):
        # mmengine's "cpu" collection pickles each rank's results into a shared folder (.dist_test);
        # its device collection is all_gather_object, which under gloo runs on the CPU: no file
        super().__init__(collect_device="gpu", prefix=prefix)
        self.lane_metric = metric(benchmark, **options)
        self.lane_metric.check_names(names)  # now, not at the end of the first epoch
        self.read_sample = sample_reader(sample)
        self.names = names

    def process(self, data_batch: Any, data_samples: Sequence[Any]) -> None:
        for sample in data_samples:
            frame, lanes, scores, fields = self.read_sample(sample)
            self.results.append(self.lane_metric.record(frame, lanes, scores, **fields))

    def compute_metrics(self, results: list) -> dict[str, Any]:
        try:
            return self.lane_metric.compute_records(results, self.names)
        except MetricInputError as error:
            # computed on rank 0 only: raised here, the other ranks would wait for its broadcast
            # for ever; sent as the result instead, it is raised on every rank by evaluate
            return {_REFUSED: str(error)}

    def evaluate(self, size: int) -> dict:
        found = super().evaluate(size)
        refused = [message for key, message in found.items() if key.endswith(_REFUSED)]
        if refused:
            raise MetricInputError(refused[0])
        return found


_REFUSED = "roneld-eval refused"
