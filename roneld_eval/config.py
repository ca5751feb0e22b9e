"""The evaluation configuration: one frozen tree, read from TOML presets and overridden by the CLI.

Every constant of a protocol lives here with the official value as its default and its
source in a comment, and every number has a range (RANGES). Presets, TOML files, `--set`
(`parse_setting`) and the library all build the same dataclasses, which check types and
ranges when built, so a bad value is one ConfigError wherever it comes from. Stages receive
only their own part. `EvalConfig.to_dict()` is what `summary.json` records, and `to_toml()`
writes a file `--config` reads back to an equal configuration. A value is checked against its
field in config_values; plug-in methods are plugin_methods'; presets, thresholds and the TOML
writer are modules of their own.
"""

from __future__ import annotations

import dataclasses
import difflib
import os
import stat
import sys
from dataclasses import dataclass, field, fields, replace
from decimal import Decimal
from pathlib import Path
from typing import Any

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - exercised on Python 3.10 only
    import tomli as tomllib

from .errors import ConfigError
from .limits import CONFIG
from .geometry import MapGeometry
from .model import Frame
from .presets import nearest, preset_path, resolve_config_path
from .thresholds import TALLEST_IMAGE, parse_rows, parse_thresholds
from .toml_text import toml_key, toml_value
from .methods import METHOD_TABLE, PAPER, PAPER_PAIR
from .config_values import Range, typed
from .plugin_methods import (  # noqa: F401 (METHODS: where callers find it)
    METHODS,
    PLUGIN_TIME_LIMIT_S,
    PluginMethod,
    check_method_name,
    methods_from_table,
)
from . import plugin_methods



def map_formats() -> tuple[str, ...]:
    """Every maps format a configuration may name: the registered ones (maps/formats.py, names
    read from the metadata), and "lanes": another detector's lane files, drawn into maps."""
    from .maps.formats import LANE_FILES, names

    return names() + (LANE_FILES,)

# Those that output the two ego lanes only (RONELD keeps the active lanes): their official F1
# over all lanes counts the outer lanes as missed, which a reader must be told.
EGO_LANES_ONLY = frozenset(name for name, facts in METHOD_TABLE.items() if facts.ego_lanes_only)
ON_ERROR = ("fail", "skip")



# The thinnest line the rasteriser draws as OpenCV does (see RANGES).
MIN_LINE_THICKNESS = 2
# The widest line drawn: a wider one costs time and memory with the square of its width (at 1000 px,
# some 7 s and 0.4 GB a frame), and no lane is that wide.
MAX_LINE_THICKNESS = 1000


def check_lane_width(width: int) -> None:
    """Refuse a lane width the scorers do not draw (one line, before any work)."""
    if isinstance(width, bool) or not isinstance(width, int):
        raise ConfigError(f"lane width must be a whole number of pixels, got {width!r}")
    if width < MIN_LINE_THICKNESS:
        raise ConfigError(f"lane width must be at least {MIN_LINE_THICKNESS}, got {width}: the C++ evaluator draws "
                          "width 1 as a thin 8-connected line, which is not emulated here")
    if width > MAX_LINE_THICKNESS:
        raise ConfigError(f"lane width must be at most {MAX_LINE_THICKNESS} px, got {width}")

# The range of every numeric setting, checked the same way for presets, TOML files, `--set`
# and the library (each dataclass checks its fields when built). Sources of the defaults are
# beside the fields; the bounds keep a typo from running for hours or drawing nonsense.
RANGES: dict[str, Range] = {
    "dataset.image_width": Range(0, 100_000),  # 0: the benchmark's (filled in where the run starts)
    "dataset.image_height": Range(0, TALLEST_IMAGE),
    "dataset.limit": Range(1),  # clips
    "maps.width": Range(1, 10_000),  # reference map size in pixels (maps of another size rescale)
    "maps.height": Range(1, 10_000),
    "maps.crop_top_px": Range(0, 100_000),  # also: inside the image, above crop_bottom_px
    "maps.crop_bottom_px": Range(1, 100_000),
    "maps.lane_channels": Range(1, 32),
    "baseline.threshold": Range(0, 1, high_open=True),  # probability a row maximum must exceed
    "baseline.min_points": Range(2, 10_000),  # a lane needs two points to be a line
    "baseline.existence_threshold": Range(0, 1),
    "roneld.center_ratio": Range(0, 1, low_open=True, high_open=True),
    "roneld.lane_ratio": Range(0, 1, high_open=True),
    # OpenCV draws thickness 1 as a thin 8-connected line, not as the thick polyline drawn
    # here for 2 and more: 1 is refused rather than scored differently from the official tools.
    "paper.gt_thickness_px": Range(MIN_LINE_THICKNESS, MAX_LINE_THICKNESS),
    "paper.pred_thickness_px": Range(MIN_LINE_THICKNESS, MAX_LINE_THICKNESS),
    "official.iou_threshold": Range(0, 1, high_open=True),  # TP when IoU > threshold
    "official.lane_width_px": Range(MIN_LINE_THICKNESS, MAX_LINE_THICKNESS),
    "workers": Range(1, 1024),
}
# Settings that no longer exist, with what to write instead.
REMOVED_SETTINGS = {
    "roneld.pft": (
        "roneld.pft was removed: preceding-frame tracking is chosen by the method; use "
        'methods = ["baseline", "roneld-nopft"] to run RONELD without it, or add "roneld-nopft" '
        'beside "roneld" (pft_ablation = true) for the ablation'
    ),
}


def _qualified(section: str, name: str) -> str:
    return f"{section}.{name}" if section else name


def _check_fields(record, section: str) -> None:
    """Type- and range-check every field of a config dataclass in place (normalised: 1 -> 1.0)."""
    for item in fields(record):
        if not section and item.name in ("plugins", "source"):
            continue  # checked by EvalConfig itself (each PluginMethod checks its fields)
        section_type = _SECTION_TYPES.get(item.name) if not section else None
        value = getattr(record, item.name)
        if section_type is not None:
            if not isinstance(value, section_type):
                raise ConfigError(f"[{item.name}] must be a {section_type.__name__}, got {value!r}")
            continue
        qualified = _qualified(section, item.name)
        checked = typed(qualified, str(item.type), value, RANGES.get(qualified))
        if checked is not value:
            object.__setattr__(record, item.name, checked)


@dataclass(frozen=True)
class DatasetConfig:
    """Which benchmark, where it lies, and how much of it to read. The benchmark is a name only:
    the run's edge (roneld_eval.api.configured) checks it is installed and fills in its image size,
    so building a configuration asks no registry."""

    name: str = ""  # a registered benchmark (roneld_eval.benchmarks); "" = the one bundling the fixture
    image_width: int = 0  # 0 = the benchmark's image size
    image_height: int = 0
    data_root: str | None = None
    list_file: str | None = None  # what lists the frames, as the benchmark reads it (its own default)
    limit: int | None = None  # at most this many clips, in dataset order

    def __post_init__(self):
        _check_fields(self, "dataset")

    @property
    def sized(self) -> bool:
        """Whether the image size is known (given, or filled in from the benchmark's)."""
        return self.image_width > 0 and self.image_height > 0


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
        _check_fields(self, "maps")
        if self.format not in map_formats():
            raise ConfigError(f"maps format must be one of {', '.join(map_formats())}, got {self.format!r}")


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
        _check_fields(self, "baseline")
        parse_rows(self.rows)


@dataclass(frozen=True)
class RoneldParams:
    """RONELD's camera constants (czming/RONELD-Lane-Detection).

    Preceding-frame tracking is not a parameter: the method chooses it ('roneld' tracks,
    'roneld-nopft' does not).
    """

    center_ratio: float = 0.5  # vehicle centre column / map width
    lane_ratio: float = 0.0  # horizon height / map height from the bottom (TuSimple: 0.6)

    def __post_init__(self):
        _check_fields(self, "roneld")


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
        _check_fields(self, "paper")
        if self.thickness_rule not in ("width", "height"):
            raise ConfigError(f"thickness_rule must be 'width' or 'height', got {self.thickness_rule!r}")
        if self.prediction_rounding not in ("nearest", "truncate"):
            raise ConfigError(
                f"prediction_rounding must be 'nearest' or 'truncate', got {self.prediction_rounding!r}"
            )
        parse_thresholds(self.thresholds)

    def thickness(self, base_px: int, map_width: int, map_height: int, rule: str | None = None) -> int:
        """Line thickness in map pixels for a thickness given at the 800x288 reference (by
        `rule`, this configuration's when None)."""
        if (rule or self.thickness_rule) == "width":
            value = int(Decimal(base_px * map_width) / Decimal(800) + Decimal("0.5"))
        else:
            value = (base_px * map_height) // 288
        if value < MIN_LINE_THICKNESS:
            raise ConfigError(
                f"a {base_px} px line at the 800x288 reference is {value} px on {map_width}x{map_height} maps; "
                f"lines thinner than {MIN_LINE_THICKNESS} px are not drawn as OpenCV draws them (raise "
                f"paper.gt_thickness_px / paper.pred_thickness_px, or use larger maps)")
        return value

    def other_rule_note(self, map_width: int, map_height: int) -> str | None:
        """One line for maps on which the two thickness rules draw differently (not proportional
        to 800x288), naming both and the flag to the other: the accuracy moves with the rule
        (on the real 976x351 CULane clip, RONELD's gain by several points), so neither is silent."""
        other = "height" if self.thickness_rule == "width" else "width"
        pairs = {rule: (self.thickness(self.gt_thickness_px, map_width, map_height, rule),
                        self.thickness(self.pred_thickness_px, map_width, map_height, rule))
                 for rule in (self.thickness_rule,)}
        try:
            pairs[other] = (self.thickness(self.gt_thickness_px, map_width, map_height, other),
                            self.thickness(self.pred_thickness_px, map_width, map_height, other))
        except ConfigError:  # too thin to draw by the other rule: not an alternative to offer
            return None
        if pairs[self.thickness_rule] == pairs[other]:
            return None
        words = {"width": "the paper's text", "height": "the authors' code"}
        (gt, pred), (other_gt, other_pred) = pairs[self.thickness_rule], pairs[other]
        return (f"on these {map_width}x{map_height} maps the paper's accuracy drew ground truth {gt} px and "
                f"predictions {pred} px (paper.thickness_rule = \"{self.thickness_rule}\", "
                f"{words[self.thickness_rule]}); {words[other]} draws {other_gt} and {other_pred} px: "
                f"--set paper.thickness_rule={other}")


@dataclass(frozen=True)
class OfficialParams:
    """The official CULane evaluator's settings (SCNN tools/lane_evaluation/Run.sh)."""

    iou_threshold: float = 0.5  # Run.sh: iou=0.5
    lane_width_px: int = 30  # Run.sh: w_lane=30

    def __post_init__(self):
        _check_fields(self, "official")

# The label of lanes read from another detector's lane files (--maps-format lanes) when no model
# is named: the lane-file presets (configs/lanes-*.toml) say the same.
LANES_MODEL = "detector"


# A worker spends about 0.5 s loading numba's kernels and scipy before its first frame, as long
# as it then takes to evaluate some 250-400 frames (1.4-2.1 ms each: the fixture, bench_run.py).
# With no `workers` given, a run starts at most one worker per this many frames, so a small run
# does not wait for workers it cannot keep busy (evaluation.pool.pool_size).
FRAMES_PER_DEFAULT_WORKER = 250


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
    # "roneld" runs RONELD with preceding-frame tracking, "roneld-nopft" without: the only PFT switch.
    methods: tuple[str, ...] = PAPER_PAIR
    pft_ablation: bool = False  # only adds "roneld-nopft" to the methods
    workers: int | None = None  # None: all cores, at most one per FRAMES_PER_DEFAULT_WORKER frames
    save_lanes: bool = False
    on_error: str = "fail"
    # Extractors outside the package that `methods` names ([methods.NAME] tables, --method).
    plugins: tuple[PluginMethod, ...] = ()
    # The file it was read from, if any: what a problem found once its benchmark's facts are
    # filled in (roneld_eval.resolve) names. Not a setting: config.toml does not hold it.
    source: str | None = field(default=None, compare=False, repr=False)

    def __post_init__(self):
        _check_fields(self, "")
        if not self.model.strip():
            raise ConfigError("model is empty: it labels every table and figure (e.g. --set model=CLRNet)")
        methods = self.methods
        if self.pft_ablation and PAPER.ours not in methods:
            raise ConfigError(f"the PFT ablation compares {PAPER.ours} with {PAPER.without_tracking}: add "
                              f"{PAPER.ours} to the methods (or drop --pft-ablation)")
        if self.pft_ablation and PAPER.without_tracking not in methods:
            methods = methods + (PAPER.without_tracking,)
        object.__setattr__(self, "methods", methods)
        if not methods:
            raise ConfigError("at least one method is needed")
        if len(set(methods)) != len(methods):
            raise ConfigError(f"a method is listed twice: {', '.join(methods)}")
        object.__setattr__(self, "plugins", self._plugins_used(methods))
        if self.on_error not in ON_ERROR:
            raise ConfigError(f"on_error must be one of {', '.join(ON_ERROR)}, got {self.on_error!r}")
        if self.dataset.sized:  # else checked once the benchmark's size is filled in (api.configured)
            self._check_image_rows()

    def _check_image_rows(self) -> None:
        crop_bottom = self.maps.crop_bottom_px
        if crop_bottom is not None and crop_bottom > self.dataset.image_height:
            raise ConfigError(
                f"maps crop_bottom_px {crop_bottom} is below the {self.dataset.image_height}-row image"
            )
        rows = parse_rows(self.baseline.rows)
        if rows.stop > self.dataset.image_height:
            raise ConfigError(
                f"baseline.rows {self.baseline.rows!r} must lie inside the {self.dataset.image_height}-row "
                f"image (stop <= {self.dataset.image_height})"
            )
        _ = self.geometry  # building it validates the crop against the image

    def _plugins_used(self, methods: tuple[str, ...]) -> tuple[PluginMethod, ...]:
        """The plug-ins `methods` names, in its order; a name nobody defines is looked up among
        the installed packages' extractors (and recorded with its entry, so config.toml reruns)."""
        if not isinstance(self.plugins, (tuple, list)) or not all(isinstance(p, PluginMethod) for p in self.plugins):
            raise ConfigError(f"plugins must be PluginMethod records, got {self.plugins!r}")
        defined = {plugin.name: plugin for plugin in self.plugins}
        if len(defined) != len(self.plugins):
            raise ConfigError("a plug-in method is defined twice")
        used = []
        installed: dict[str, str] | None = None
        for method in methods:
            check_method_name(method)
            if method in METHODS:
                continue
            if method not in defined:
                installed = plugin_methods.installed_extractors() if installed is None else installed
                if method not in installed:
                    known = list(METHODS) + sorted(set(defined) | set(installed))
                    raise ConfigError(f"unknown method {method!r}{nearest(method, known)}; choose from "
                                      f"{', '.join(known)}, or add your own with --method {method}=module:callable")
                defined[method] = PluginMethod(method, installed[method])
            used.append(defined[method])
        return tuple(used)

    def with_plugin(self, name: str, entry: str) -> "EvalConfig":
        """A copy that also runs the extractor `entry` ("module:callable") as method `name`."""
        plugin = PluginMethod(name, entry)
        plugins = tuple(p for p in self.plugins if p.name != name) + (plugin,)
        methods = self.methods if name in self.methods else self.methods + (name,)
        return replace(self, methods=methods, plugins=plugins)

    @property
    def geometry(self) -> MapGeometry:
        """The configured map-to-image geometry (maps of another size rescale it)."""
        if not self.dataset.sized:
            raise ConfigError("the configuration gives no image size (0: its benchmark's, filled in where a run, "
                              "evaluate or replay starts: roneld_eval.resolve.configured); give [dataset] "
                              "image_width and image_height to use it on its own")
        return MapGeometry(
            image_width=self.dataset.image_width,
            image_height=self.dataset.image_height,
            map_width=self.maps.width,
            map_height=self.maps.height,
            crop_top_px=self.maps.crop_top_px,
            crop_bottom_px=self.maps.crop_bottom_px,
        )

    def geometry_of(self, frame: Frame) -> MapGeometry:
        """The geometry of one frame: the configured one, at the frame's own size where it has
        one (its crop rows scaled with its height)."""
        if frame.image_size is None:
            return self.geometry
        return self.geometry.at_image_size(*frame.image_size)

    # ---- building -------------------------------------------------------------------

    @classmethod
    def from_dict(cls, data: dict[str, Any], source: str | None = None) -> "EvalConfig":
        """Build from a nested dict as TOML gives it; unknown keys are errors.

        Values are checked as every other way of building a configuration checks them
        (types and RANGES); a problem names `source`, the file it was read from (kept as the
        configuration's `source`, named by what is checked once the benchmark's facts are filled
        in), or "configuration" without one.
        """
        where = source or "configuration"
        if not isinstance(data, dict):
            raise ConfigError(f"{where}: a configuration must be a table of settings")
        kwargs: dict[str, Any] = {}
        known = {f.name for f in fields(cls)} - {"plugins", "source"}  # plug-ins are [methods.NAME] tables
        try:
            for key, value in data.items():
                if key not in known:
                    raise ConfigError(f"unknown key {key!r}")
                if key == "methods" and isinstance(value, dict):
                    kwargs["methods"], kwargs["plugins"] = methods_from_table(value)
                    continue
                section_type = _SECTION_TYPES.get(key)
                if section_type is None:
                    kwargs[key] = value
                    continue
                if not isinstance(value, dict):
                    raise ConfigError(f"[{key}] must be a table")
                section_known = {f.name for f in fields(section_type)}
                for name in value:
                    removed = REMOVED_SETTINGS.get(f"{key}.{name}")
                    if removed is not None:
                        raise ConfigError(removed)
                    if name not in section_known:
                        raise ConfigError(f"[{key}] unknown key {name!r}")
                kwargs[key] = section_type(**value)
            return cls(**kwargs, source=source)
        except ConfigError as error:
            raise ConfigError(f"{where}: {error}") from None

    @classmethod
    def from_toml(cls, path: str | Path) -> "EvalConfig":
        """Read a TOML file (a preset name also works: see `preset_path`)."""
        path = resolve_config_path(path)
        return cls.from_toml_text(_read_config_text(path), source=str(path))

    @classmethod
    def from_toml_text(cls, text: str, source: str | None = None) -> "EvalConfig":
        """Build from TOML text (what `to_toml` writes), read from the file `source` if given."""
        return cls.from_dict(_toml_data(text, source), source=source)

    @classmethod
    def from_toml_over(cls, path: str | Path, base: str | Path) -> "EvalConfig":
        """The TOML file (or preset) `path` read over `base` (a benchmark's default preset): every
        setting the file leaves out is the base's, section by section, so that a file of a few
        settings for TuSimple keeps TuSimple's rows and crop instead of the dataclasses' defaults
        (SCNN's on CULane); what the file gives wins, and a problem is said naming the file."""
        path, base = resolve_config_path(path), resolve_config_path(base)
        top = _toml_data(_read_config_text(path), str(path))
        under = _toml_data(_read_config_text(base), str(base))
        layered = dict(under)
        for key, value in top.items():
            sectioned = key in _SECTION_TYPES and isinstance(value, dict) and isinstance(under.get(key), dict)
            layered[key] = {**under[key], **value} if sectioned else value
        return cls.from_dict(layered, source=str(path))

    @classmethod
    def preset(cls, name: str) -> "EvalConfig":
        """A bundled preset by name, e.g. ``scnn-culane``."""
        return cls.from_toml(preset_path(name))

    def with_overrides(self, **overrides: Any) -> "EvalConfig":
        """A copy with dotted-path overrides, e.g. ``**{"dataset.limit": 3, "workers": 2}``.

        None values are ignored, so unset CLI options leave the file's values alone. All
        overrides apply together and the result is checked once (types and RANGES).
        """
        top: dict[str, Any] = {}
        sections: dict[str, dict[str, Any]] = {}
        for dotted, value in overrides.items():
            if value is None:
                continue
            section, name = _setting_field(dotted)[:2]
            if section:
                sections.setdefault(section, {})[name] = value
            else:
                top[name] = value
        changed = {section: replace(getattr(self, section), **values) for section, values in sections.items()}
        if not top and not changed:
            return self
        return replace(self, **changed, **top)

    def without_pft(self) -> "EvalConfig":
        """The same run with RONELD's preceding-frame tracking off: 'roneld' becomes 'roneld-nopft'."""
        methods = self.methods
        if PAPER.ours in methods and PAPER.without_tracking in methods:
            raise ConfigError(
                "cannot turn PFT off: the configuration runs RONELD both with and without PFT "
                "(pft_ablation or methods); drop one of them"
            )
        if PAPER.ours not in methods and PAPER.without_tracking not in methods:
            raise ConfigError(f"cannot turn PFT off: RONELD is not among the methods ({', '.join(methods)})")
        return replace(self, methods=tuple(PAPER.without_tracking if m == PAPER.ours else m for m in methods))

    # ---- writing --------------------------------------------------------------------

    def to_dict(self) -> dict[str, Any]:
        """Nested plain data (JSON- and TOML-friendly; None values kept)."""
        data = dataclasses.asdict(self)
        del data["plugins"], data["source"]
        if self.plugins:  # then methods are [methods.NAME] tables, as config files write them
            tables = {plugin.name: plugin.to_table() for plugin in self.plugins}
            data["methods"] = {name: tables.get(name, {}) for name in self.methods}
        else:
            data["methods"] = list(self.methods)
        return data

    def to_toml(self) -> str:
        """TOML text that `from_toml` reads back to an equal configuration."""
        top, tables = [], []
        for key, value in self.to_dict().items():
            if key == "methods" and isinstance(value, dict):
                for name, table in value.items():
                    lines = [f"[methods.{toml_key(name)}]"]
                    lines += [f"{toml_key(k)} = {toml_value(v)}" for k, v in table.items()]
                    tables.append("\n".join(lines))
            elif isinstance(value, dict):
                lines = [f"[{key}]"]
                lines += [f"{k} = {toml_value(v)}" for k, v in value.items() if v is not None]
                tables.append("\n".join(lines))
            elif value is not None:
                top.append(f"{key} = {toml_value(value)}")
        return "\n".join(top) + "\n\n" + "\n\n".join(tables) + "\n"


_SECTION_TYPES = {
    "dataset": DatasetConfig,
    "maps": MapsConfig,
    "baseline": BaselineParams,
    "roneld": RoneldParams,
    "paper": PaperMetricParams,
    "official": OfficialParams,
}


def _setting_field(dotted: str) -> tuple[str, str, str]:
    """(section, name, type annotation) of a setting such as 'paper.thresholds' or 'workers'."""
    if dotted in REMOVED_SETTINGS:
        raise ConfigError(REMOVED_SETTINGS[dotted])
    section, _, name = dotted.strip().rpartition(".")
    if section:
        owner = _SECTION_TYPES.get(section)
    else:
        owner = EvalConfig
    types = {} if owner is None else {f.name: str(f.type) for f in fields(owner)}
    if name not in types or (not section and (name in _SECTION_TYPES or name == "plugins")):
        every = [_qualified(s, f.name) for s, t in _SECTION_TYPES.items() for f in fields(t)]
        every += [f.name for f in fields(EvalConfig) if f.name not in _SECTION_TYPES and f.name != "plugins"]
        close = difflib.get_close_matches(dotted, every, n=1)
        hint = f" (did you mean {close[0]}?)" if close else ""
        raise ConfigError(f"unknown setting {dotted!r}{hint}")
    return section, name, types[name]


def parse_setting(text: str) -> tuple[str, Any]:
    """A `--set` value 'section.key=value' -> ('section.key', value typed by the field).

    The value is read as TOML (1, 0.5, true, "x", [..]) where the field is a number, a flag or
    a list; a text field takes the text as written (0.5 stays '0.5', quotes are removed), and a
    list also takes comma-separated names (methods=baseline,roneld). The value is then checked
    exactly as a TOML file's is, when the configuration is built.
    """
    key, equals, raw = text.partition("=")
    key, raw = key.strip(), raw.strip()
    if not equals or not key:
        raise ConfigError(f"--set needs SECTION.KEY=VALUE, got {text!r}")
    _, _, annotation = _setting_field(key)
    base = annotation.split("|")[0].strip()
    try:
        parsed = tomllib.loads(f"v = {raw}")
        value, understood = parsed.get("v"), len(parsed) == 1 and "v" in parsed
    except (tomllib.TOMLDecodeError, RecursionError):
        value, understood = None, False
    if base == "str":
        return key, value if understood and isinstance(value, str) else raw
    if base.startswith("tuple"):
        return key, value if understood and isinstance(value, (str, list)) else raw
    return key, value if understood else raw


def _toml_data(text: str, source: str | None) -> Any:
    """TOML text as the dict it holds, or one ConfigError line naming `source`."""
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as error:
        raise ConfigError(f"{source or 'configuration'}: not valid TOML: {error}") from None
    except RecursionError:  # tomllib recurses once per nested array
        raise ConfigError(f"{source or 'configuration'}: not a configuration: nested too deeply") from None


def _read_config_text(path: Path) -> str:
    """A config file's text: a regular UTF-8 file (a BOM is dropped), or one ConfigError line."""
    try:
        info = os.stat(path)
        if not stat.S_ISREG(info.st_mode):
            raise ConfigError(f"{path}: not a regular file")
        if info.st_size > CONFIG.bytes:  # a configuration is a few kB
            raise ConfigError(f"{path}: {CONFIG.problem(info.st_size)}")
        with open(path, "rb") as handle:
            data = handle.read(info.st_size + 1)  # within the bound, checked above
    except OSError as error:
        raise ConfigError(f"{path}: cannot read: {error.strerror}") from None
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as error:
        raise ConfigError(
            f"{path}: not UTF-8 text (byte 0x{data[error.start]:02x} at offset {error.start}); save it as UTF-8"
        ) from None
    return text[1:] if text.startswith("\ufeff") else text
