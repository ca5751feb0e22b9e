"""A benchmark's official metric in memory, for training loops: `roneld_eval.metric(name, **options)`.

The benchmark gives the metric's core (`MetricCore`, from `Benchmark.metric(**options)`): the
frames of its list in order, one frame's counts from lanes held in memory, and the scores from
every frame's counts. This module is the face a training loop calls, the same for every
benchmark: frames may come in any order and in batches, a frame given twice, one not in the list
or malformed lanes is one error that leaves the state as it was, and `compute()` combines the
counts in the list's order (so any order of updates gives the same bits), frames never updated
counting as the official tool counts a missing prediction file.
"""

from __future__ import annotations

import inspect
import os
from dataclasses import dataclass, fields, is_dataclass
from typing import Any, Callable, Generic, Iterable, Mapping, Protocol, Sequence, TypeVar

import numpy as np

from .errors import RoneldEvalError
from .lanes_io import MAX_PREDICTED_COORDINATE
from .model import Lane


class MetricInputError(RoneldEvalError, ValueError):
    """What `update` refused (the frame named), the metric's state unchanged."""


class MetricCore(Protocol):
    """What a benchmark's official metric gives the in-memory face."""

    name: str  # the benchmark's
    frames: tuple[str, ...]  # every frame of the list, in its order (as the benchmark names a frame)

    def frame_counts(self, frame: str, lanes: Any, scores: Any, **fields: Any) -> Any:
        """One frame's counts from its lanes as the benchmark's files hold them, in memory (and
        the other fields of its line, as TuSimple's `h_samples` and `run_time`); a ValueError
        saying what is wrong with them. Reads nothing the metric keeps."""

    def tables(self, counts: Sequence[Any | None]) -> dict[str, Any]:
        """The tables `score NAME` writes from the same counts (scoring.PlainTable by name)."""

    def compute(self, counts: Sequence[Any | None]) -> dict[str, float]:
        """The scores (`<metric>@<threshold in percent>`, `/<category>` appended for a category)
        from every frame's counts in the list's order, None where a frame was never updated."""


@dataclass(frozen=True)
class MetricState:
    """What `Metric.state()` hands over (to another process, or `merge`): each updated frame's
    counts, and the metric they belong to."""

    benchmark: str
    options: tuple[tuple[str, Any], ...]
    counts: Mapping[str, Any]


class Metric:
    """The official metric of one benchmark, fed one frame (or a batch) at a time."""

    def __init__(self, core: MetricCore, options: Mapping[str, Any]):
        self.core = core
        self.options = tuple(sorted((key, _option_text(value)) for key, value in options.items()))
        self._listed = frozenset(core.frames)
        self._counts: dict[str, Any] = {}

    @property
    def frames_updated(self) -> int:
        return len(self._counts)

    def update(self, frame: str, lanes: Any, scores: Any = None, **fields: Any) -> None:
        """One frame's lanes (and their scores, where the benchmark reads them; other fields of
        its prediction, as TuSimple's `h_samples` and `run_time`)."""
        frame = self.frame_name(frame)
        self._counts[frame] = self._checked(frame, lanes, scores, set(), fields)

    def frame_name(self, frame: Any) -> Any:
        """The frame as the list names it: a leading '/' dropped (CULane's list writes one, and
        the frames are named without it)."""
        if isinstance(frame, str) and frame not in self._listed and frame.startswith("/"):
            return frame.lstrip("/")
        return frame

    def check_names(self, names: str | None) -> None:
        """Refuse, before any frame, key names the benchmark does not offer (`compute(names)`)."""
        if names is not None and not callable(getattr(self.core, f"compute_as_{names}", None)):
            offered = [n[len("compute_as_"):] for n in dir(self.core) if n.startswith("compute_as_")]
            raise MetricInputError(f"{self.core.name} offers no key names {names!r} (offered: "
                                   f"{', '.join(offered) or 'none'})")

    def update_many(self, frames: Sequence[str], lanes: Sequence[Any], scores: Sequence[Any] | None = None) -> None:
        """A batch of frames: all of them taken, or (one refused) none."""
        frames, lanes = list(frames), list(lanes)
        scores = None if scores is None else list(scores)
        if len(frames) != len(lanes) or (scores is not None and len(scores) != len(frames)):
            raise MetricInputError(f"update_many: {len(frames)} frames, {len(lanes)} lane lists"
                                   + ("" if scores is None else f", {len(scores)} score lists")
                                   + ": one of each per frame")
        batch: dict[str, Any] = {}
        for k, frame in enumerate(frames):
            frame = self.frame_name(frame)
            batch[frame] = self._checked(frame, lanes[k], None if scores is None else scores[k], batch, {})
        self._counts.update(batch)

    def record(self, frame: str, lanes: Any, scores: Any = None, **fields: Any) -> tuple[str, Any]:
        """One frame's (name, counts), checked as `update` checks them but not kept: what a
        framework's metric hands between processes (`add_records` takes them back)."""
        frame = self.frame_name(frame)
        return frame, self._checked(frame, lanes, scores, set(), fields, kept=False)

    def add_records(self, records: Iterable[tuple[str, Any]]) -> None:
        """Frames' (name, counts) from `record`, in any order, from any process: a frame given
        twice with the same counts is kept once (a distributed sampler's padding), with other
        counts refused; all of them taken, or (one refused) none."""
        records = list(records)
        for frame, _ in records:
            if not isinstance(frame, str) or frame not in self._listed:
                raise MetricInputError(f"{frame!r} is not a frame of this {self.core.name} list")
        self._counts.update(kept_once(records, self._counts, "recorded twice with different lanes"))

    def compute_records(self, records: Iterable[tuple[str, Any]], names: str | None = None) -> dict[str, float]:
        """`compute(names)` of these records alone (a framework's gathered `record`s), the metric
        left without counts: the drawn ground truth stays for the next epoch."""
        self.reset()
        try:
            self.add_records(records)
            return self.compute(names)
        finally:
            self.reset()

    def _checked(self, frame: Any, lanes: Any, scores: Any, batch, fields: dict[str, Any], kept: bool = True) -> Any:
        if not isinstance(frame, str) or frame not in self._listed:
            example = self.core.frames[0] if self.core.frames else "none"
            raise MetricInputError(f"{frame!r} is not a frame of this {self.core.name} list (frames are named as "
                                   f"the list names them, e.g. {example!r})")
        if kept and (frame in self._counts or frame in batch):
            raise MetricInputError(f"{frame}: given twice to this metric (reset() starts again)")
        try:
            return self.core.frame_counts(frame, lanes, scores, **fields)
        except RoneldEvalError as error:
            raise MetricInputError(f"{frame}: {error}") from None
        except (TypeError, ValueError) as error:
            raise MetricInputError(f"{frame}: {error}") from None

    def compute(self, names: str | None = None) -> dict[str, float]:
        """Every score, frames combined in the list's order; frames never updated count as the
        official tool counts a missing prediction (no lanes; TuSimple's refuses: an error).
        `names`: another framework's key names, where the benchmark offers them (CULane's
        "clrernet": the keys CLRerNet's mmengine metric logs)."""
        self.check_names(names)
        compute = self.core.compute if names is None else getattr(self.core, f"compute_as_{names}")
        try:
            return compute([self._counts.get(frame) for frame in self.core.frames])
        except ValueError as error:
            raise MetricInputError(str(error)) from None

    def tables(self) -> dict[str, Any]:
        """The tables `score NAME` writes (`official`: official.csv's rows, method '-', ...), as
        plain tables (`.to_frame()` gives a DataFrame, `.to_csv()` the file's text)."""
        return self.core.tables([self._counts.get(frame) for frame in self.core.frames])

    def reset(self) -> None:
        self._counts = {}

    def state(self) -> MetricState:
        return MetricState(self.core.name, self.options, dict(self._counts))

    def merge(self, other: "Metric | MetricState") -> None:
        """Take another metric's frames (another process's share of the list): the same benchmark
        and options. A frame in both is kept once where its counts are the same (distributed
        samplers pad the last ranks with frames other ranks had), and refused where they differ."""
        state = other.state() if isinstance(other, Metric) else other
        if (state.benchmark, state.options) != (self.core.name, self.options):
            raise MetricInputError(f"cannot merge a {state.benchmark} metric of options {dict(state.options)} into a "
                                   f"{self.core.name} metric of options {dict(self.options)}")
        unknown = sorted(set(state.counts) - self._listed)
        if unknown:
            raise MetricInputError(f"{unknown[0]} is not a frame of this {self.core.name} list")
        differing = sorted(frame for frame in set(state.counts) & set(self._counts)
                           if not same_counts(state.counts[frame], self._counts[frame]))
        if differing:
            raise MetricInputError(f"{differing[0]}: updated in both metrics with different lanes "
                                   f"({len(differing)} frames)")
        self._counts.update(state.counts)


Truth = TypeVar("Truth")


class TruthMemo(Generic[Truth]):
    """Each frame's ground truth as a metric's core reads and draws it, kept from its first use on:
    a training loop updates the same frames every epoch, and from the second on only its
    predictions are read and drawn. A frame whose truth cannot be read is not kept (its error is
    raised again next time). Held by the core, so by the metric object: a new `metric(...)` reads
    the labels afresh (an edited label is seen), `reset()` keeps them."""

    def __init__(self, read: Callable[[str], Truth]):
        self._read = read
        self._kept: dict[str, Truth] = {}

    def __call__(self, frame: str) -> Truth:
        if frame not in self._kept:
            self._kept[frame] = self._read(frame)
        return self._kept[frame]

    def __len__(self) -> int:
        return len(self._kept)


def _option_text(value: Any) -> str:
    """An option as merge compares it: a path by the file it names (`Path(D)`, `str(D)` and `D/`
    are one folder), anything else by its repr."""
    if isinstance(value, (str, os.PathLike)) and os.path.exists(value):
        return repr(os.path.realpath(value))
    return repr(value)


def point_arrays(lanes: Any, axes: str = "x, y") -> list[np.ndarray]:
    """A frame's lanes as a detector holds them, a sequence of (N, 2) point arrays, each as float64;
    a ValueError naming the lane that is not one."""
    if isinstance(lanes, (str, bytes, Mapping)) or not hasattr(lanes, "__iter__"):
        raise ValueError(f"lanes must be a sequence of (N, 2) point arrays, got a {type(lanes).__name__}")
    if isinstance(lanes, np.ndarray) and lanes.ndim != 3:
        raise ValueError(f"lanes must be a sequence of (N, 2) point arrays, got an array of shape {lanes.shape}")
    arrays = []
    for index, lane in enumerate(lanes):
        points = numbers_of(lane, f"lane {index}")
        if points.size == 0:
            points = points.reshape(0, 2)
        if points.ndim != 2 or points.shape[1] != 2:
            raise ValueError(f"lane {index}: points must be an (N, 2) array of ({axes}), got shape {points.shape}")
        arrays.append(points)
    return arrays


def numbers_of(value: Any, what: str) -> np.ndarray:
    """A lane's points as float64, from an array, nested lists or a tensor (detached, on the CPU);
    a ValueError saying what they are instead."""
    if hasattr(value, "detach") and hasattr(value, "cpu"):  # a torch tensor, grad or not, on any device
        value = value.detach().cpu()
        if hasattr(value, "float"):
            value = value.float().numpy()  # bfloat16 has no NumPy type
    if isinstance(value, np.ma.MaskedArray) and np.ma.getmaskarray(value).any():
        raise ValueError(f"{what}: a masked array with masked points (give only the points that are there)")
    if isinstance(value, (str, bytes, dict)) or (hasattr(value, "__next__") and not hasattr(value, "__len__")):
        raise ValueError(f"{what}: points must be an (N, 2) array of numbers, got a {type(value).__name__}")
    try:
        found = np.asarray(value)
    except (ValueError, TypeError) as error:
        raise ValueError(f"{what}: points must be an (N, 2) array of numbers (rows of unequal length?): "
                         f"{error}") from None
    if found.size and found.dtype.kind not in "iuf":
        raise ValueError(f"{what}: points must be numbers, got {found.dtype} values")
    return found.astype(np.float64)


def scored_3d_lanes(lanes: Any, scores: Any, what: str, score: tuple[str, str], widths: tuple[int, ...] = (3,),
                    short_above: float | None = None) -> tuple[list[np.ndarray], np.ndarray]:
    """A frame's 3-D lanes and a score each, as the 3-D benchmarks' metrics take them: (N, 3) point
    arrays (N, 2 where `widths` allow it) of at least two points (or fewer where the lane's score
    is at most `short_above`: never compared), one finite score a lane; a ValueError naming the
    lane that is not so, as `score NAME` refuses such lanes in files. `score`: what a score is
    called, one and several ("probability", "probabilities")."""
    arrays = [numbers_of(lane, f"{what} {k}") for k, lane in enumerate(lanes)]
    chances = numbers_of(scores if scores is not None else [], f"{what} {score[1]}")
    if chances.shape != (len(arrays),):
        raise ValueError(f"give one {score[0]} for each of the {len(arrays)} {what}s")
    for k, array in enumerate(arrays):
        if (array.ndim != 2 or array.shape[1] not in widths
                or (len(array) < 2 and (short_above is None or chances[k] > short_above))):
            raise ValueError(f"{what} {k}: points must be an (N, 3) array of (x, y, z), at least two, got shape "
                             f"{array.shape}")
        if not np.isfinite(array).all():
            raise ValueError(f"{what} {k}: its points must be finite numbers")
    if not np.isfinite(chances).all():
        raise ValueError(f"every {what}'s {score[0]} must be a finite number")
    return arrays, chances


def pixel_lanes(values: Any) -> tuple[Lane, ...]:
    """Lanes as a detector holds them: a sequence of (N, 2) arrays of (x, y) image pixels, as a
    `.lines.txt` lists them (the C++ evaluator's float32 applies as when written and read)."""
    lanes = []
    for index, points in enumerate(point_arrays(values)):
        if not np.isfinite(points).all():
            raise ValueError(f"lane {index}: a coordinate is NaN or infinite")
        if points.size and np.abs(points).max() > MAX_PREDICTED_COORDINATE:
            raise ValueError(f"lane {index}: a coordinate lies more than 2^24 px from the image origin")
        lanes.append(Lane(points))
    return tuple(lanes)


def kept_once(records: Iterable[tuple[str, Any]], earlier: Mapping[str, Any], clash: str) -> dict[str, Any]:
    """The records' frames not in `earlier`, each once: a frame given again (among them or in
    `earlier`) with the same counts is skipped, as a distributed sampler's padding is; with other
    counts it is refused (`clash`: how it was given)."""
    fresh: dict[str, Any] = {}
    for frame, counts in records:
        for before in (fresh, earlier):
            if frame in before:
                if not same_counts(before[frame], counts):
                    raise MetricInputError(f"{frame}: {clash}")
                break
        else:
            fresh[frame] = counts
    return fresh


def same_counts(a: Any, b: Any) -> bool:
    """Whether two frames' counts are the same, bit for bit (numbers, arrays, or dataclasses and
    tuples of them; NaN equal to NaN)."""
    if is_dataclass(a) and is_dataclass(b) and type(a) is type(b):
        return all(same_counts(getattr(a, f.name), getattr(b, f.name)) for f in fields(a))
    if isinstance(a, (tuple, list)) and isinstance(b, (tuple, list)):
        return len(a) == len(b) and all(same_counts(x, y) for x, y in zip(a, b))
    x, y = np.asarray(a), np.asarray(b)
    if x.dtype.kind in "fc" or y.dtype.kind in "fc":
        return x.shape == y.shape and bool(np.array_equal(x, y, equal_nan=True))
    return x.shape == y.shape and bool(np.array_equal(x, y))


def metric(name: str, **options: Any) -> Metric:
    """The official metric of benchmark `name` in memory; `options` as `score NAME` takes them
    (for CULane: data_root, list_file, iou or preset, width)."""
    from .errors import ConfigError
    from .resolve import benchmark_named

    benchmark = benchmark_named(name)
    make = getattr(type(benchmark), "metric", None)
    if make is None:
        raise ConfigError(f"{benchmark.display_name} offers no in-memory metric yet (score its files with "
                          f"`roneld-eval score {name}`)")
    target = getattr(make, "target", None)
    if target is not None:
        _check_options(name, inspect.signature(target(benchmark)), options)
    try:
        return Metric(make(benchmark, **options), options)
    except (TypeError, ValueError) as error:  # a value of the wrong kind (an InputError names its file)
        raise ConfigError(f"metric({name!r}): {error}") from None


def _check_options(name: str, signature: inspect.Signature, options: Mapping[str, Any]) -> None:
    """Unknown and missing options, in one line listing the ones the metric takes."""
    from .errors import ConfigError

    taken = [p for p in signature.parameters.values() if p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)]
    names = [p.name for p in taken]
    required = [p.name for p in taken if p.default is p.empty]
    unknown = [key for key in options if key not in names]
    missing = [key for key in required if key not in options]
    if unknown:
        said = f"unknown option{'s' if len(unknown) > 1 else ''} {', '.join(unknown)}"
    elif missing:
        said = f"missing {', '.join(missing)}"
    else:
        return
    raise ConfigError(f"metric({name!r}): {said}; it takes {', '.join(names)} (required: "
                      f"{', '.join(required) or 'none'})")
