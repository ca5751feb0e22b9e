"""The evaluation configuration: one frozen tree, read from TOML presets and overridden by the CLI.

Every constant of a protocol lives here with the official value as its default and its
source in a comment. Stages receive only their own part. `EvalConfig.to_dict()` is what
`summary.json` records, and `to_toml()` writes a file `--config` reads back.
"""

from __future__ import annotations

import dataclasses
import math
import sys
from dataclasses import dataclass, field, fields, replace
from decimal import Decimal, InvalidOperation
from importlib import resources
from pathlib import Path
from typing import Any

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - exercised on Python 3.10 only
    import tomli as tomllib

from .errors import ConfigError
from .geometry import MapGeometry

DATASETS = ("culane", "tusimple")
MAP_FORMATS = ("npy", "npz", "scnn-png")
METHODS = ("baseline", "roneld", "roneld-nopft")
ON_ERROR = ("fail", "skip")

# Image sizes of the benchmarks (CULane: Pan et al. 2018; TuSimple: tusimple-benchmark).
IMAGE_SIZES = {"culane": (1640, 590), "tusimple": (1280, 720)}
DEFAULT_PRESETS = {"culane": "scnn-culane", "tusimple": "scnn-tusimple"}


@dataclass(frozen=True)
class DatasetConfig:
    """Which benchmark, where it lies, and how much of it to read."""

    name: str = "culane"
    image_width: int = 1640
    image_height: int = 590
    data_root: str | None = None
    # CULane: a list file of image paths (default <root>/list/test.txt);
    # TuSimple: the label file (default <root>/test_label.json).
    list_file: str | None = None
    limit: int | None = None  # at most this many clips, in dataset order

    def __post_init__(self):
        if self.name not in DATASETS:
            raise ConfigError(f"dataset must be one of {', '.join(DATASETS)}, got {self.name!r}")
        if self.limit is not None and self.limit < 1:
            raise ConfigError(f"limit must be at least 1, got {self.limit}")


@dataclass(frozen=True)
class MapsConfig:
    """How the stored probability maps are laid out and what part of the frame they cover."""

    root: str | None = None
    format: str = "npy"
    width: int = 800  # default map size; maps of another size are accepted and rescaled
    height: int = 288
    crop_top_px: int = 0  # first image row the map covers
    crop_bottom_px: int | None = None  # one past the last; None = image height
    background_channel: bool = False  # arrays hold a background channel before the lanes
    lane_channels: int = 4
    npz_key: str = "probs"  # .npz: array name of the maps; optional "exist" beside it

    def __post_init__(self):
        if self.format not in MAP_FORMATS:
            raise ConfigError(f"maps format must be one of {', '.join(MAP_FORMATS)}, got {self.format!r}")
        if self.lane_channels < 1:
            raise ConfigError(f"lane_channels must be at least 1, got {self.lane_channels}")


@dataclass(frozen=True)
class BaselineParams:
    """The models' own lane extraction (SCNN tools/prob2lines/getLane.m and main.m)."""

    threshold: float = 0.3  # getLane.m: a row's maximum counts when value/255 > 0.3
    # 0-based image rows sampled, as start:stop:step. CULane: 18 rows 589, 569, ..., 249
    # (main.m writes y = 590 - 20*i - 1); TuSimple: its h_samples 160..710.
    rows: str = "249:590:20"
    min_points: int = 2  # getLane.m: a lane with fewer than 2 points is dropped
    existence_threshold: float = 0.5  # main.m keeps channels whose exist flag is 1

    def __post_init__(self):
        parse_rows(self.rows)
        if not 0 <= self.threshold < 1:
            raise ConfigError(f"baseline threshold must be in [0, 1), got {self.threshold}")


@dataclass(frozen=True)
class RoneldParams:
    """RONELD's camera constants and the PFT switch (czming/RONELD-Lane-Detection)."""

    center_ratio: float = 0.5  # vehicle centre column / map width
    lane_ratio: float = 0.0  # horizon height / map height from the bottom (TuSimple: 0.6)
    pft: bool = True  # preceding-frame tracking

    def __post_init__(self):
        if not 0 < self.center_ratio < 1:
            raise ConfigError(f"center_ratio must be in (0, 1), got {self.center_ratio}")
        if not 0 <= self.lane_ratio < 1:
            raise ConfigError(f"lane_ratio must be in [0, 1), got {self.lane_ratio}")


@dataclass(frozen=True)
class PaperMetricParams:
    """The RONELD paper's protocol (section IV-B): ego lanes drawn at map resolution."""

    # "width": round(px * map_width / 800), the paper's text ("adjusted based on model output
    # width"); "height": int(px * map_height / 288), what the authors' code did. Both give
    # 16/30 px on SCNN's 800x288 maps.
    thickness_rule: str = "width"
    gt_thickness_px: int = 16
    pred_thickness_px: int = 30
    # Map coordinates snap to pixels: "nearest" for both; "truncate" draws predictions with
    # C's int() as the RONELD reference code does (ground truth stays "nearest").
    prediction_rounding: str = "nearest"
    thresholds: str = "0.30:0.50:0.01"

    def __post_init__(self):
        if self.thickness_rule not in ("width", "height"):
            raise ConfigError(f"thickness_rule must be 'width' or 'height', got {self.thickness_rule!r}")
        if self.prediction_rounding not in ("nearest", "truncate"):
            raise ConfigError(
                f"prediction_rounding must be 'nearest' or 'truncate', got {self.prediction_rounding!r}"
            )
        parse_thresholds(self.thresholds)

    def thickness(self, base_px: int, map_width: int, map_height: int) -> int:
        """Line thickness in map pixels for a thickness given at the 800x288 reference."""
        if self.thickness_rule == "width":
            value = int(Decimal(base_px * map_width) / Decimal(800) + Decimal("0.5"))
        else:
            value = (base_px * map_height) // 288
        return max(1, value)


@dataclass(frozen=True)
class OfficialParams:
    """The official CULane evaluator's settings (SCNN tools/lane_evaluation/Run.sh)."""

    iou_threshold: float = 0.5  # Run.sh: iou=0.5
    lane_width_px: int = 30  # Run.sh: w_lane=30


@dataclass(frozen=True)
class EvalConfig:
    """Everything a run needs; validated once when built."""

    model: str = "SCNN"  # display name of the model whose maps these are
    dataset: DatasetConfig = field(default_factory=DatasetConfig)
    maps: MapsConfig = field(default_factory=MapsConfig)
    baseline: BaselineParams = field(default_factory=BaselineParams)
    roneld: RoneldParams = field(default_factory=RoneldParams)
    paper: PaperMetricParams = field(default_factory=PaperMetricParams)
    official: OfficialParams = field(default_factory=OfficialParams)
    methods: tuple[str, ...] = ("baseline", "roneld")
    pft_ablation: bool = False
    workers: int | None = None  # None: all cores
    save_lanes: bool = False
    on_error: str = "fail"

    def __post_init__(self):
        methods = tuple(self.methods)
        if self.pft_ablation and "roneld-nopft" not in methods:
            methods = methods + ("roneld-nopft",)
        object.__setattr__(self, "methods", methods)
        if not methods:
            raise ConfigError("at least one method is needed")
        for method in methods:
            if method not in METHODS:
                raise ConfigError(f"unknown method {method!r}; choose from {', '.join(METHODS)}")
        if len(set(methods)) != len(methods):
            raise ConfigError(f"a method is listed twice: {', '.join(methods)}")
        if self.workers is not None and self.workers < 1:
            raise ConfigError(f"workers must be at least 1, got {self.workers}")
        if self.on_error not in ON_ERROR:
            raise ConfigError(f"on_error must be one of {', '.join(ON_ERROR)}, got {self.on_error!r}")
        crop_bottom = self.maps.crop_bottom_px
        if crop_bottom is not None and crop_bottom > self.dataset.image_height:
            raise ConfigError(
                f"maps crop_bottom_px {crop_bottom} is below the {self.dataset.image_height}-row image"
            )
        self.geometry  # validates the crop against the image

    @property
    def geometry(self) -> MapGeometry:
        """The configured map-to-image geometry (maps of another size rescale it)."""
        return MapGeometry(
            image_width=self.dataset.image_width,
            image_height=self.dataset.image_height,
            map_width=self.maps.width,
            map_height=self.maps.height,
            crop_top_px=self.maps.crop_top_px,
            crop_bottom_px=self.maps.crop_bottom_px,
        )

    # ---- building -------------------------------------------------------------------

    @classmethod
    def from_dict(cls, data: dict[str, Any], source: str = "configuration") -> "EvalConfig":
        """Build from a nested dict as TOML gives it; unknown keys are errors."""
        kwargs: dict[str, Any] = {}
        sections = {f.name: f for f in fields(cls)}
        for key, value in data.items():
            if key not in sections:
                raise ConfigError(f"{source}: unknown key {key!r}")
            section_type = _SECTION_TYPES.get(key)
            if section_type is not None:
                if not isinstance(value, dict):
                    raise ConfigError(f"{source}: [{key}] must be a table")
                kwargs[key] = _build_section(section_type, value, f"{source} [{key}]")
            else:
                kwargs[key] = _coerce(cls, key, value, source)
        try:
            return cls(**kwargs)
        except TypeError as error:  # pragma: no cover - guarded by the checks above
            raise ConfigError(f"{source}: {error}") from None

    @classmethod
    def from_toml(cls, path: str | Path) -> "EvalConfig":
        """Read a TOML file (a preset name also works: see `preset_path`)."""
        path = resolve_config_path(path)
        try:
            with open(path, "rb") as handle:
                data = tomllib.load(handle)
        except tomllib.TOMLDecodeError as error:
            raise ConfigError(f"{path}: not valid TOML: {error}") from None
        except OSError as error:
            raise ConfigError(f"{path}: cannot read: {error.strerror}") from None
        return cls.from_dict(data, source=str(path))

    @classmethod
    def preset(cls, name: str) -> "EvalConfig":
        """A bundled preset by name, e.g. ``scnn-culane``."""
        return cls.from_toml(preset_path(name))

    def with_overrides(self, **overrides: Any) -> "EvalConfig":
        """A copy with dotted-path overrides, e.g. ``**{"dataset.limit": 3, "workers": 2}``.

        None values are ignored, so unset CLI options leave the file's values alone.
        """
        config = self
        for dotted, value in overrides.items():
            if value is None:
                continue
            section, _, name = dotted.rpartition(".")
            if section:
                current = getattr(config, section)
                if name not in {f.name for f in fields(current)}:
                    raise ConfigError(f"unknown setting {dotted!r}")
                config = replace(config, **{section: replace(current, **{name: value})})
            else:
                if name not in {f.name for f in fields(config)}:
                    raise ConfigError(f"unknown setting {dotted!r}")
                config = replace(config, **{name: value})
        return config

    # ---- writing --------------------------------------------------------------------

    def to_dict(self) -> dict[str, Any]:
        """Nested plain data (JSON- and TOML-friendly; None values kept)."""
        data = dataclasses.asdict(self)
        data["methods"] = list(self.methods)
        return data

    def to_toml(self) -> str:
        """TOML text that `from_toml` reads back to an equal configuration."""
        top, tables = [], []
        for key, value in self.to_dict().items():
            if isinstance(value, dict):
                lines = [f"[{key}]"]
                lines += [f"{k} = {_toml_value(v)}" for k, v in value.items() if v is not None]
                tables.append("\n".join(lines))
            elif value is not None:
                top.append(f"{key} = {_toml_value(value)}")
        return "\n".join(top) + "\n\n" + "\n\n".join(tables) + "\n"


_SECTION_TYPES = {
    "dataset": DatasetConfig,
    "maps": MapsConfig,
    "baseline": BaselineParams,
    "roneld": RoneldParams,
    "paper": PaperMetricParams,
    "official": OfficialParams,
}


def _build_section(section_type, values: dict[str, Any], source: str):
    known = {f.name for f in fields(section_type)}
    kwargs = {}
    for key, value in values.items():
        if key not in known:
            raise ConfigError(f"{source}: unknown key {key!r}")
        kwargs[key] = _coerce(section_type, key, value, source)
    return section_type(**kwargs)


def _coerce(owner, key: str, value: Any, source: str) -> Any:
    """Check a TOML value against the field's annotation (TOML has no None, lists for tuples)."""
    annotation = str({f.name: f.type for f in fields(owner)}[key])
    if "tuple" in annotation:
        if isinstance(value, str):
            value = [part.strip() for part in value.split(",") if part.strip()]
        if not isinstance(value, (list, tuple)):
            raise ConfigError(f"{source}: {key} must be a list")
        return tuple(value)
    if annotation.startswith("bool"):
        if not isinstance(value, bool):
            raise ConfigError(f"{source}: {key} must be true or false")
        return value
    if annotation.startswith("int"):
        if isinstance(value, bool) or not isinstance(value, int):
            raise ConfigError(f"{source}: {key} must be an integer")
        return value
    if annotation.startswith("float"):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ConfigError(f"{source}: {key} must be a number")
        return float(value)
    if annotation.startswith("str"):
        if not isinstance(value, str):
            raise ConfigError(f"{source}: {key} must be a string")
    return value


def _toml_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    text = str(value).replace("\\", "\\\\").replace('"', '\\"')
    return f'"{text}"'


# ---- presets -------------------------------------------------------------------------


def _presets_folder() -> Path:
    """configs/ as installed (roneld_eval.configs), or beside the package in a source checkout."""
    try:
        return Path(str(resources.files("roneld_eval.configs")))
    except ModuleNotFoundError:
        return Path(__file__).resolve().parents[1] / "configs"


def preset_names() -> list[str]:
    """Names of the bundled presets (the TOML files in configs/)."""
    return sorted(entry.name[:-5] for entry in _presets_folder().iterdir() if entry.name.endswith(".toml"))


def preset_path(name: str) -> Path:
    """The file of a bundled preset."""
    if name not in preset_names():
        raise ConfigError(f"unknown preset {name!r}; presets: {', '.join(preset_names())}")
    return _presets_folder() / f"{name}.toml"


def resolve_config_path(value: str | Path) -> Path:
    """A config file path, or a preset name when no such file exists."""
    path = Path(value)
    if path.is_file():
        return path
    if path.suffix == "" and str(value) in preset_names():
        return preset_path(str(value))
    raise ConfigError(f"{value}: no such config file or preset (presets: {', '.join(preset_names())})")


# ---- number ranges -------------------------------------------------------------------


def parse_rows(spec: str) -> range:
    """Image rows 'start:stop:step' (Python range semantics, 0-based)."""
    try:
        start, stop, step = (int(part) for part in spec.split(":"))
    except ValueError:
        raise ConfigError(f"rows must look like 'start:stop:step' with integers, got {spec!r}") from None
    if step <= 0 or start < 0 or stop <= start:
        raise ConfigError(f"rows {spec!r} must have 0 <= start < stop and a positive step")
    return range(start, stop, step)


@dataclass(frozen=True)
class Thresholds:
    """IoU thresholds as exact decimals: `labels` like '0.30', `values` the nearest doubles."""

    labels: tuple[str, ...]
    values: tuple[float, ...]

    def __len__(self) -> int:
        return len(self.values)


def parse_thresholds(spec: str) -> Thresholds:
    """'0.30:0.50:0.01' (inclusive) or '0.5' or '0.3,0.5' -> exact decimal thresholds.

    Values are built as integer multiples of the step divided last, so 0.30 is the double
    nearest 0.3, never 0.30000000000000004.
    """
    try:
        if ":" in spec:
            start, stop, step = (Decimal(part.strip()) for part in spec.split(":"))
            if step <= 0 or stop < start:
                raise ConfigError(f"thresholds {spec!r} need start <= stop and a positive step")
            count = (stop - start) / step
            if count != count.to_integral_value():
                raise ConfigError(f"thresholds {spec!r}: the step does not divide stop - start")
            decimals = [start + step * i for i in range(int(count) + 1)]
        else:
            decimals = [Decimal(part.strip()) for part in spec.split(",") if part.strip()]
    except InvalidOperation:
        raise ConfigError(f"thresholds must be numbers like '0.30:0.50:0.01', got {spec!r}") from None
    if not decimals:
        raise ConfigError("no thresholds given")
    places = max(max(-d.as_tuple().exponent, 0) for d in decimals)
    places = max(places, 2)
    for value in decimals:
        if not 0 <= value < 1:
            raise ConfigError(f"IoU thresholds must lie in [0, 1), got {value}")
    labels = tuple(f"{value:.{places}f}" for value in decimals)
    # Exact: a Decimal with few digits converts to the nearest double.
    values = tuple(float(value) for value in decimals)
    if len(set(labels)) != len(labels):
        raise ConfigError(f"thresholds {spec!r} repeat a value")
    assert all(math.isfinite(v) for v in values)
    return Thresholds(labels=labels, values=values)
