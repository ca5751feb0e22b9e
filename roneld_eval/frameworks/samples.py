"""A framework's prediction for one frame, as its data sample holds it, read into what
`Metric.record` takes: (frame, lanes, scores, other fields)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Mapping

import numpy as np

from ..in_memory import MetricInputError

Sample = tuple[str, Any, Any, dict[str, Any]]
FIELDS = ("h_samples", "run_time", "categories")  # the other fields some benchmarks' update takes


def plain_sample(sample: Mapping[str, Any]) -> Sample:
    """`{"frame": ..., "lanes": [...], "scores": [...] (optional), ...}`: the names of
    `Metric.update`'s arguments (and its fields: `h_samples`, `run_time`, `categories`)."""
    if not isinstance(sample, Mapping) or "frame" not in sample or "lanes" not in sample:
        raise MetricInputError("a data sample must be a mapping with 'frame' and 'lanes' (and optionally 'scores'), "
                               f"got {_shape(sample)}; give sample=... to read another layout")
    return sample["frame"], sample["lanes"], sample.get("scores"), {k: sample[k] for k in FIELDS if k in sample}


@dataclass(frozen=True)
class ClrernetSample:
    """CLRerNet's data sample (`{"lanes": [Lane, ...], "metainfo": {"sub_img_name": ...}}`, its
    Lane called with y in [0, 1) giving x in [0, 1)), its lanes sampled as its CULaneMetric writes
    them (hirotomusiker/CLRerNet 4bd8e7d, get_prediction_string): every `y_step` image rows, the
    points with x in [0, 1) scaled to the image, bottom first, a lane of fewer than 2 points
    dropped, each coordinate as its 5-decimal text reads back."""

    width: int
    height: int
    y_step: int = 2

    def __post_init__(self):
        for name in ("width", "height", "y_step"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise MetricInputError(f"sample's {name} must be a whole number of pixels, got {value!r}")

    def __call__(self, sample: Mapping[str, Any]) -> Sample:
        try:
            frame, lanes = sample["metainfo"]["sub_img_name"], sample["lanes"]
        except (KeyError, TypeError):
            raise MetricInputError("a CLRerNet data sample needs 'lanes' and metainfo's 'sub_img_name', got "
                                   f"{_shape(sample)}") from None
        ys = np.arange(0, self.height, self.y_step) / self.height
        out = []
        for index, lane in enumerate(lanes):
            if not callable(lane):
                raise MetricInputError(f"{frame}: lane {index} is a {type(lane).__name__}, not a CLRerNet Lane "
                                       "(called with y in [0, 1) to give x)")
            xs = np.asarray(lane(ys), dtype=np.float64)
            valid = (xs >= 0) & (xs < 1)
            points = np.stack([xs[valid] * self.width, ys[valid] * self.height], axis=1)[::-1]
            if len(points) >= 2:
                out.append(np.array([[float(f"{x:.5f}"), float(f"{y:.5f}")] for x, y in points.tolist()]))
        return frame, out, None, {}


def sample_reader(spec: str | Mapping[str, Any] | Callable[[Any], Sample]) -> Callable[[Any], Sample]:
    """"plain", {"style": "clrernet", "width": W, "height": H[, "y_step": 2]} (a config file's
    form), or a function of a sample returning (frame, lanes, scores, fields)."""
    if callable(spec):
        return spec
    if spec == "plain":
        return plain_sample
    if isinstance(spec, Mapping) and spec.get("style") == "clrernet":
        options = {key: value for key, value in spec.items() if key != "style"}
        try:
            return ClrernetSample(**options)
        except TypeError as error:  # an option it does not take
            raise MetricInputError(f"sample={dict(spec)!r}: {error}") from None
    raise MetricInputError(f"sample must be 'plain', {{'style': 'clrernet', 'width': ..., 'height': ...}} or a "
                           f"function, got {spec!r}")


def _shape(sample: Any) -> str:
    if isinstance(sample, Mapping):
        return f"a mapping with keys {sorted(map(str, sample))}"
    return f"a {type(sample).__name__}"
