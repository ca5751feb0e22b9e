"""The benchmarks a run can score against, each one object implementing `Benchmark`: how its
dataset is read, how a frame is scored the official way, how the official table is built and
shown, where a clip's labels lie, and how lanes are written.

Benchmarks register under the entry-point group `roneld_eval.benchmarks` (name = module:object),
CULane and TuSimple as any third party's package would (pyproject.toml). The rest of the tool
asks `names()`, and looks a benchmark up once where work enters (roneld_eval.resolve), handing
the object to each stage; it knows no benchmark by name.
"""

from __future__ import annotations

import functools
import importlib.metadata
import inspect
import re
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Mapping, Protocol, Sequence

from ..entry_points import in_group
from ..errors import ConfigError

if TYPE_CHECKING:  # annotations only: `score` starts without pandas or the extractors' kernels, and
    # config, which asks this registry for a benchmark's facts, is not imported back (no import cycle)
    import pandas as pd

    from ..config import EvalConfig
    from ..model import Clip, Dataset, Frame, Lane

    from ..extract.protocol import Prediction


class OfficialRecord(Protocol):
    """One frame's official score of one method, as its benchmark defines it."""

    def to_json(self) -> Any: ...


class OfficialTally(Protocol):
    """The official table gathered one frame record at a time, kept compact: what a run's main
    process holds instead of every record."""

    def add(self, method: str, relpath: str, record: Any) -> None:
        """One frame's record: the frames of a clip come in frame order, every method's in turn."""

    def end_clip(self, clip_id: str) -> None:
        """Every frame of the clip has been added: where clip-level metrics (temporal ones, over
        consecutive frames) finish the clip."""

    def table(self) -> pd.DataFrame:
        """The official table: one row per method (and category), methods in the given order."""


@dataclass(frozen=True)
class LaneFile:
    """Where one frame's lanes go: `name`, a path under the run's lanes/ folder that begins with
    the method's name (METHOD/<frame>.lines.txt, METHOD/predictions.json), its `text`, and whether
    the text is appended to a file shared by all frames (`append`: one line per frame, its text
    ending in a newline) or is the whole file."""

    name: str
    text: str
    append: bool = False


@dataclass(frozen=True)
class CategoryPanel:
    """categories.png's second panel: a benchmark's official score per category (columns method,
    category, score in [0, 1]), its title, the score's short name and the run's settings behind
    it (None when not known), and what to say where a method outputs the ego lanes only (which
    an all-lanes score counts against it)."""

    table: "pd.DataFrame"
    title: str
    score_name: str
    settings: str | None
    ego_lanes_note: str


class Benchmark(Protocol):
    """What the tool needs of a benchmark. Members a benchmark may have besides, asked for with
    getattr: `scorer`, `metric`, `merge_parts`, `synth_maps_format`, and `diagnose_run(lanes,
    dataset, frames, config, loc_iou, announce)` (`run --diagnose`: the lanes a run saved, scored
    as `score NAME --diagnose` scores them, over the frames it scored; report.diagnosis.Diagnosed)."""

    name: str  # as configurations and the command line name it (the entry point's name)
    display_name: str  # as tables and titles print it
    image_size: tuple[int, int]  # (width, height) of its frames
    # the configuration of its default model: a bundled preset name or a TOML file; None for a
    # benchmark scored from lane files alone (`score NAME`; its `read` says why `run` is not offered)
    default_preset: str | None
    frames_per_clip: int  # what `synth` generates by default
    fixture: str | None  # folder of roneld_eval._fixture holding its bundled fixture, if any
    # numba kernel groups its official scoring runs (compiled before the workers start)
    kernel_groups: tuple[str, ...]
    # said after "maps missing for N frames of K clips" (what a clip needs), or ""
    missing_maps_hint: str
    # a detector's lane files in its official prediction format, what `run --maps-format lanes`
    # reads back (maps.lanes.LinesPerFrame or JsonLinesFile, the inverse of `lane_file`), or None
    detector_lanes: Any

    def read(self, root: Path, list_file: Path | None, limit: int | None, errors: list | None,
             labels: bool) -> Dataset:
        """The dataset under `root`, clips in order; see `datasets.read_dataset`. With
        `labels=False` a benchmark may leave each clip's labels to `with_labels`."""

    def with_labels(self, clip: Clip, root: Path, errors: list | None) -> Clip:
        """The clip with its labels read (called only where `read` left them out)."""

    def synthesize(self, out: Path, clips: int, frames: int, seed: int, maps_format: str, progress) -> Any:
        """Write a synthetic set (`synth.SynthResult`): OUT/data in the benchmark's layout, OUT/maps
        (in `maps_format`: its attribute `synth_maps_format` when `synth` is not told, else "npy")."""

    def label_paths(self, clip: Clip, data_root: Path | None, label_file: Path | None) -> list[Path]:
        """Every file holding this clip's labels (what resume must see unchanged)."""

    def prepare(self, frame: Frame, config: EvalConfig) -> Any:
        """Work shared by every method's scoring of one frame (the ground truth's masks)."""

    def score(self, prepared: Any, prediction: Prediction, config: EvalConfig) -> OfficialRecord:
        """One method's official record of one frame."""

    def tally(self, methods: Sequence[str], dataset: Dataset, config: EvalConfig) -> "OfficialTally":
        """An empty official table for these methods, to `add` records to frame by frame."""

    def decode(self, value: Any) -> OfficialRecord:
        """The inverse of `OfficialRecord.to_json` (TypeError/ValueError when malformed)."""

    def lane_file(self, method: str, frame: Frame, lanes: Sequence[Lane]) -> LaneFile:
        """One frame's lanes in the benchmark's official prediction format."""

    def score_command(self) -> Any:
        """`roneld-eval score NAME`: a click command scoring lane files, or None."""

    # ---- how its official scores are shown and read back ----

    # official.csv's columns as compare reads it back, name -> kind: "text", "count" (an integer >= 0),
    # "number" (finite) or "optional number" (empty is NaN); those it may lack (written by older
    # versions); and the columns naming a row
    official_columns: Mapping[str, str]
    official_optional: Mapping[str, str]
    official_key: tuple[str, ...]

    def official_protocol(self, protocol: Any) -> str | None:
        """The run's settings behind its official scores (report.tables.Protocol), or None."""

    def official_note(self, protocol: Any) -> str:
        """What report.html says of the official table (`protocol` may be None)."""

    def check_official(self, path: Path, table: "pd.DataFrame") -> None:
        """Refuse (InputError) an official.csv read back whose numbers cannot be this benchmark's."""

    def official_comparison(self, groups: Sequence[Any]) -> tuple[Any, str]:
        """compare's official table of run groups of this benchmark (a comparison Grid), and its text."""

    def category_panel(self, official: "pd.DataFrame", protocol: Any) -> CategoryPanel | None:
        """Its official score by category beside the paper's accuracy in categories.png (drawn
        where the dataset has categories), or None to show the accuracy alone."""


ENTRY_POINT_GROUP = "roneld_eval.benchmarks"


def from_module(module: str, name: str, call: bool = False):
    """A benchmark member taken from a module of the benchmark's own folder when first used (so
    that naming a benchmark imports none of its scoring): `name` itself (`scorer`,
    `score_command`), or with `call` the member's arguments passed to it (`metric(**options)`,
    `merge_parts(parts, out)`). `module` is relative to the benchmark object's package."""

    def target(self) -> Any:
        import importlib

        return getattr(importlib.import_module(module, type(self).__module__.rpartition(".")[0]), name)

    def member(self, *args: Any, **kwargs: Any) -> Any:
        value = target(self)
        return value(*args, **kwargs) if call else value

    member.__doc__ = f"{name} of {module}" + (" called with these arguments" if call else "")
    member.target = target  # type: ignore[attr-defined]  # what is called, for its signature
    return member


def declared_command(module: str):
    """`score_command` of a benchmark that declares its command (a `ScoreCommand` named COMMAND in
    `module` of its folder): the click command roneld_eval.score_commands builds from it."""

    def score_command(self) -> Any:
        import importlib

        from ..score_commands import built

        spec = importlib.import_module(module, type(self).__module__.rpartition(".")[0]).COMMAND
        return built(spec, self.scorer)

    score_command.__doc__ = f"the command declared in {module}"
    return score_command


_OWN = __name__.split(".")[0] + "."
# What every benchmark must have, and what `run` needs besides (a benchmark scored from lane
# files only has default_preset None and need not have these).
REQUIRED = ("display_name", "image_size", "default_preset", "frames_per_clip", "fixture", "score_command")
RUN_REQUIRED = ("kernel_groups", "missing_maps_hint", "detector_lanes", "read", "with_labels", "synthesize",
                "label_paths", "prepare", "score", "tally", "decode", "lane_file", "official_columns",
                "official_optional", "official_key", "official_protocol", "official_note", "check_official",
                "official_comparison", "category_panel")


@functools.cache
def _entry_points() -> dict[str, importlib.metadata.EntryPoint]:
    """Name -> entry point. This package's own benchmarks keep their names: another package on
    sys.path registering one of them does not replace it (else the first found wins, as for
    console scripts)."""
    found: dict[str, importlib.metadata.EntryPoint] = {}
    for point in in_group(ENTRY_POINT_GROUP):
        if point.name not in found or (point.value.startswith(_OWN) and not found[point.name].value.startswith(_OWN)):
            found[point.name] = point
    return dict(sorted(found.items()))


def names() -> tuple[str, ...]:
    """Every registered benchmark's name, without importing any of them."""
    return tuple(_entry_points())


def origin(name: str) -> str:
    """Where a registered benchmark comes from, as its entry point's metadata says (nothing is
    imported): "built in", or its package, version and entry."""
    point = _entry_points()[name]
    if point.value.startswith(_OWN):
        return "built in"
    dist = getattr(point, "dist", None)
    package = f"{dist.name} {dist.version}: " if dist is not None else ""
    return f"{package}{point.value}"


def benchmark_for(name: str) -> Benchmark:
    """The benchmark registered under `name` (as `DatasetConfig.name` gives it), checked, loaded
    once. The tool calls it in one place, roneld_eval.resolve, where work enters."""
    return _loaded(name)


@functools.cache
def _loaded(name: str) -> Benchmark:
    points = _entry_points()
    if name not in points:
        known = ", ".join(points) or "none (is roneld-eval installed?)"
        raise ConfigError(f"unknown dataset {name!r}; choose from {known}")
    point = points[name]
    if not point.value.startswith(_OWN):  # a third party's: a plug-in (benchmarks.plugins)
        if not _NAME.fullmatch(name):  # `--quiet`, `../x`, `a b`
            raise ConfigError(f"benchmark {name!r} ({point.value}): a benchmark's name is lowercase letters, "
                              "digits, '-' and '_', beginning with a letter or digit (it names a command and folders)")
        from . import plugins

        benchmark = plugins.load(point)
    else:
        benchmark = point.load()
    where = f"benchmark {name!r} ({point.value})"
    if inspect.getattr_static(benchmark, "name", None) != name:
        raise ConfigError(f"{where} calls itself {inspect.getattr_static(benchmark, 'name', None)!r}")
    # Looked up statically: a benchmark may answer every other name with its own ConfigError.
    missing = [member for member in REQUIRED if inspect.getattr_static(benchmark, member, _MISSING) is _MISSING]
    if not missing and inspect.getattr_static(benchmark, "default_preset") is not None:
        missing = [member for member in RUN_REQUIRED
                   if inspect.getattr_static(benchmark, member, _MISSING) is _MISSING]
    if missing:
        raise ConfigError(f"{where} lacks {', '.join(missing)} (see roneld_eval.benchmarks.Benchmark)")
    if not point.value.startswith(_OWN):
        return plugins.PluginObject(benchmark, name, point.value)
    return benchmark


_MISSING = object()
_NAME = re.compile(r"[a-z0-9][a-z0-9_-]*")


def detector_lane_formats() -> dict[str, Any]:
    """Each built-in benchmark's format of a detector's lane files (`detector_lanes`), where it
    declares one: what says which benchmark reads the lane files a user gave another. Another
    package's are not asked: a hint must not import its code (one that hung at import delayed a
    built-in run's error by its time limit)."""
    formats = {}
    for name, point in _entry_points().items():
        if not point.value.startswith(_OWN):
            continue
        try:
            files = _loaded(name).detector_lanes
        except (ConfigError, ImportError, AttributeError):
            continue
        if files is not None:
            formats[name] = files
    return formats


def default_name() -> str:
    """The benchmark `run` evaluates when told none: the first of this package's own that bundles
    a fixture (an installed package cannot change what the bare command does)."""
    for name, point in _entry_points().items():
        if point.value.startswith(_OWN) and _loaded(name).fixture is not None:
            return name
    raise ConfigError("no installed benchmark bundles a fixture: give --dataset, --data-root and --maps-root")
