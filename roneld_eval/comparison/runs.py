"""Reading one finished run folder for `compare`, treating every file in it as untrusted input.

A run folder is what `roneld-eval run` wrote (see roneld_eval.output): its manifest, config.toml,
summary.json, accuracy.csv, per_frame.csv, runtime.csv and official.csv. Each file is checked
as it is read: a malformed CSV, JSON or TOML file, a missing column, a number that is not one,
or tables that contradict each other is an InputError naming the file (and line), never a
traceback. Nothing here compares runs with each other (see comparison/__init__.py).
"""

from __future__ import annotations

import hashlib
import os
import stat
import tomllib
from dataclasses import dataclass
from decimal import Decimal, InvalidOperation
from typing import Any
from pathlib import Path

import numpy as np
import pandas as pd

from ..errors import InputError
from ..json_fields import RepeatedKey, loads
from ..lanes_io import check_regular_file
from ..limits import RUN_TABLE

# The files compare reads; `run` always writes all of them.
RUN_FILES = ("config.toml", "summary.json", "accuracy.csv", "per_frame.csv", "runtime.csv", "official.csv")
MAX_COUNT = float(1 << 53)
MAX_RECORD_BYTES = 16 << 20  # config.toml and summary.json are a few kB; a larger one is not ours
# The RONELD paper's protocol: the settings that change what an accuracy means. Runs that differ
# in any of them measure different things (see README, "The protocols, precisely").
PROTOCOL_SETTINGS = (
    ("paper", "thickness_rule"),
    ("paper", "gt_thickness_px"),
    ("paper", "pred_thickness_px"),
    ("paper", "prediction_rounding"),
    ("official", "iou_threshold"),
    ("official", "lane_width_px"),
)
CSV_KINDS = ("text", "count", "number", "optional number")


@dataclass(frozen=True, eq=False)
class Run:
    """One finished run as compare sees it: what it measured, on what, and its tables."""

    path: Path  # the folder as the user named it
    label: str  # how tables name its model: --label, else config.toml's `model`
    model: str
    dataset: str  # 'culane', 'tusimple', ...
    benchmark: Any  # the dataset's (roneld_eval.benchmarks.Benchmark), looked up once as the run is read
    methods: tuple[str, ...]  # in accuracy.csv's order
    thresholds: tuple[Decimal, ...]  # the sweep, in accuracy.csv's order
    protocol: tuple[tuple[str, object], ...]  # (setting, value) for PROTOCOL_SETTINGS
    accuracy: pd.DataFrame  # method, threshold (Decimal), n_tp, n_gt, accuracy, roneld_gain, ci_low, ci_high
    per_frame: pd.DataFrame  # frame, side, method, iou
    runtime: pd.DataFrame  # method, frames, mean_ms, median_ms, p95_ms
    official: pd.DataFrame  # CULane: method, category, tp, fp, fn, f1; TuSimple: method, accuracy, fp, fn
    counts: dict  # summary.json's counts (clips, frames, labelled_frames, gt_lanes, ego_lanes)
    clips: int  # distinct clips among the scored frames: the bootstrap's unit
    frames_key: str  # digest of the scored frames
    truth_key: str  # digest of the ground-truth ego lanes (frame, side) and the lane counts
    results_key: str  # digest of every (frame, side, method, IoU): equal for runs of identical results
    columns: dict  # (method, accuracy.csv column) -> {threshold: value}, for quick look-ups
    # (clip, width, height) where its videos have sizes of their own (VIL-100)
    clip_sizes: tuple[tuple[str, int, int], ...] = ()

    def name(self) -> str:
        """The folder as given, for messages."""
        return str(self.path)

    @property
    def dataset_name(self) -> str:
        """How tables and titles name its dataset: its benchmark's display name."""
        return self.benchmark.display_name

    def column(self, method: str, column: str) -> dict[Decimal, float]:
        """threshold -> value of one accuracy.csv column for one method ({} without the column)."""
        return self.columns.get((method, column), {})


def read_run(path: str | Path, label: str | None = None) -> Run:
    """Read and check a finished run folder; `label` overrides config.toml's model name."""
    from ..api import check_finished_run  # the one definition of "a finished run"
    from ..output import INPUT_RUN_REMEDY, read_manifest

    folder = Path(path)
    check_finished_run(folder, "; compare takes a folder of `score` only as a checkpoint sweep, which it writes "
                               "(sweep.csv) when given several checkpoints (a glob, --pred-roots-from)")
    manifest = read_manifest(folder, INPUT_RUN_REMEDY)
    assert manifest is not None  # check_finished_run refuses a folder without one
    _check_run_files(folder, manifest["entries"])
    config = _read_toml(folder / "config.toml")
    summary = _read_json(folder / "summary.json")
    model = _setting(config, folder / "config.toml", (), "model", str)
    if not model.isprintable():  # it names the run in every table and figure
        raise InputError(folder / "config.toml", f"`model` holds control characters: {model!a}")
    dataset = _setting(config, folder / "config.toml", ("dataset",), "name", str)
    if not model.strip():
        raise InputError(folder / "config.toml", "`model` is empty")
    recorded = summary.get("dataset")
    if recorded is not None and recorded != dataset:
        raise InputError(folder / "summary.json", f"names dataset {recorded!r} but config.toml says {dataset!r}")
    counts = _counts(folder / "summary.json", summary)
    protocol = tuple((f"{section}.{key}", _protocol_value(config, section, key)) for section, key in PROTOCOL_SETTINGS)

    accuracy = read_csv(folder / "accuracy.csv", {"method": "text", "threshold": "text", "n_tp": "count",
                                                  "n_gt": "count", "accuracy": "optional number"},
                        {"roneld_gain": "optional number", "roneld_gain_ci_low": "optional number",
                         "roneld_gain_ci_high": "optional number"})
    methods, thresholds = _check_accuracy(folder / "accuracy.csv", accuracy)
    per_frame = read_csv(folder / "per_frame.csv", {"frame": "text", "side": "text", "method": "text",
                                                    "iou": "number"})
    frames_key, truth_key, clips = _check_per_frame(folder / "per_frame.csv", per_frame, accuracy, methods,
                                                    thresholds, counts)
    runtime = read_csv(folder / "runtime.csv", {"method": "text", "frames": "count", "mean_ms": "optional number",
                                                "median_ms": "optional number", "p95_ms": "optional number"})
    _unique(folder / "runtime.csv", runtime, ["method"])
    benchmark = _benchmark_of(folder, dataset)
    official = read_csv(folder / "official.csv", benchmark.official_columns, benchmark.official_optional)
    _unique(folder / "official.csv", official, list(benchmark.official_key))
    benchmark.check_official(folder / "official.csv", official)
    return Run(path=folder, label=label if label is not None else model, model=model, dataset=dataset,
               benchmark=benchmark,
               methods=methods, thresholds=thresholds, protocol=protocol, accuracy=accuracy, per_frame=per_frame,
               runtime=runtime, official=official, counts=dict(counts), clips=clips, frames_key=frames_key,
               truth_key=truth_key, results_key=_results_key(per_frame), columns=_columns(accuracy),
               clip_sizes=_clip_sizes(folder / "summary.json", summary))


def _check_run_files(folder: Path, entries) -> None:
    for name in RUN_FILES:
        file = folder / name
        if name not in entries or not file.is_file():
            raise InputError(file, "missing from this run folder: it is not the complete output of `roneld-eval run`")


def _counts(path: Path, summary: dict) -> dict:
    """summary.json's counts: clips, labelled frames, ground-truth and ego lanes."""
    counts = summary.get("counts")
    if not isinstance(counts, dict) or not all(
            isinstance(counts.get(key), int) and not isinstance(counts.get(key), bool) and counts[key] >= 0
            for key in ("clips", "labelled_frames", "gt_lanes", "ego_lanes")):
        raise InputError(path, "`counts` must hold clips, labelled_frames, gt_lanes and ego_lanes as non-negative "
                               "integers")
    return counts


def _clip_sizes(path: Path, summary: dict) -> tuple[tuple[str, int, int], ...]:
    sizes = summary.get("clip_sizes", {})
    if not isinstance(sizes, dict) or not all(
            isinstance(size, list) and len(size) == 2 and all(isinstance(v, int) and not isinstance(v, bool) and v > 0
                                                               for v in size) for size in sizes.values()):
        raise InputError(path, "`clip_sizes` must map each clip to its width and height in pixels")
    return tuple(sorted((str(clip), size[0], size[1]) for clip, size in sizes.items()))


def _benchmark_of(folder: Path, dataset: str):
    from ..benchmarks import names
    from ..resolve import benchmark_named

    if dataset not in names():
        raise InputError(folder / "config.toml", f"names dataset {dataset!r}, which no installed benchmark provides "
                                                 f"(installed: {', '.join(names())})")
    return benchmark_named(dataset)


# ---- files ------------------------------------------------------------------------------------

def _read_bytes(path: Path, limit: int = MAX_RECORD_BYTES) -> bytes:
    try:
        info = os.stat(path)
        if not stat.S_ISREG(info.st_mode):
            raise InputError(path, "not a regular file")
        if info.st_size > limit:
            raise InputError(path, f"too large ({info.st_size:,} bytes) for what `roneld-eval run` writes there")
        with open(path, "rb") as handle:
            return handle.read(limit + 1)
    except OSError as error:
        raise InputError(path, f"cannot read: {error.strerror}") from None


def _read_toml(path: Path) -> dict:
    try:
        return tomllib.loads(_read_bytes(path).decode("utf-8"))
    except UnicodeDecodeError:
        raise InputError(path, "not UTF-8 text") from None
    except tomllib.TOMLDecodeError as error:
        raise InputError(path, f"not valid TOML: {error}") from None
    except RecursionError:  # tomllib recurses once per nested array
        raise InputError(path, "not TOML this tool wrote: nested too deeply") from None


def _read_json(path: Path) -> dict:
    try:
        data = loads(_read_bytes(path).decode("utf-8"))
    except UnicodeDecodeError:
        raise InputError(path, "not UTF-8 text") from None
    except RepeatedKey as error:
        raise InputError(path, str(error)) from None
    except (ValueError, RecursionError) as error:
        raise InputError(path, f"not valid JSON: {error}") from None
    if not isinstance(data, dict):
        raise InputError(path, "must hold a JSON object")
    return data


def _setting(data: dict, path: Path, sections: tuple[str, ...], key: str, kind: type):
    where: dict | None = data
    for section in sections:
        where = where.get(section) if isinstance(where, dict) else None
    value = where.get(key) if isinstance(where, dict) else None
    if not isinstance(value, kind):
        name = ".".join(sections + (key,))
        raise InputError(path, f"`{name}` is missing or not a {kind.__name__}")
    return value


def _protocol_value(config: dict, section: str, key: str):
    value = config.get(section, {}).get(key) if isinstance(config.get(section), dict) else None
    return value if isinstance(value, (str, int, float, bool)) or value is None else str(value)


def read_csv(path: Path, columns: dict[str, str], optional: dict[str, str] | None = None) -> pd.DataFrame:
    """A CSV file with the named columns, each checked: 'text', 'count' (integer >= 0), 'number'
    (finite) or 'optional number' (empty is NaN). Extra columns are ignored."""
    table = _text_table(path)
    missing = [name for name in columns if name not in table.columns]
    if missing:
        raise InputError(path, f"has no column {', '.join(missing)}: not the table `roneld-eval run` writes "
                               f"(columns {', '.join(columns)})")
    wanted = dict(columns)
    for name, kind in (optional or {}).items():
        if name in table.columns:
            wanted[name] = kind
    out: dict[str, pd.Series | np.ndarray] = {}
    for name, kind in wanted.items():
        raw = table[name].to_numpy(object)
        if kind == "text":
            out[name] = pd.Series(raw, dtype=object)  # plain objects: pandas' str arrays iterate slowly
            continue
        numbers, first = column_numbers(raw, kind)
        if first is not None:
            raise InputError(path, f"column {name}: {raw[first]!r} is not {EXPECTED[kind]}", line=first + 2)
        out[name] = numbers.astype(np.int64) if kind == "count" else numbers
    return pd.DataFrame(out, columns=list(wanted))


def _text_table(path: Path) -> pd.DataFrame:
    """A run's CSV file as text cells, read within the size a run's table may have."""
    try:
        check_regular_file(path, "missing from this run folder", RUN_TABLE)
        return pd.read_csv(path, dtype=object, keep_default_na=False, na_filter=False, encoding="utf-8")
    except FileNotFoundError:
        raise InputError(path, "missing from this run folder") from None
    except OSError as error:
        raise InputError(path, f"cannot read: {error.strerror or error}") from None
    except UnicodeDecodeError:
        raise InputError(path, "not UTF-8 text") from None
    except pd.errors.EmptyDataError:
        raise InputError(path, "empty: not a table this tool wrote") from None
    except (pd.errors.ParserError, ValueError, OverflowError, MemoryError) as error:
        raise InputError(path, f"not a valid CSV table ({str(error).strip().splitlines()[0]})") from None


EXPECTED = {"count": "a whole number in [0, 2^53]", "number": "a finite number", "optional number": "a number or empty"}


def column_numbers(raw: np.ndarray, kind: str) -> tuple[np.ndarray, int | None]:
    """A column of a kind other than 'text' as floats, and the row of its first value that is not
    of the kind (None: all are). Also how a benchmark plug-in's official table is checked before
    it is written (benchmarks.plugins)."""
    numbers = np.asarray(pd.to_numeric(raw, errors="coerce"), np.float64).copy()
    allowed = np.zeros(len(raw), bool)  # an empty optional number
    for row in np.flatnonzero(np.isnan(numbers)):  # few: parse them one by one, spaces allowed
        text = str(raw[row]).strip()
        if kind == "optional number" and text.lower() in ("", "nan"):
            allowed[row] = True
            continue
        try:
            numbers[row] = float(text)
        except ValueError:
            pass
    bad = ~np.isfinite(numbers) & ~allowed
    if kind == "count":  # whole, and exact as a float (a count of 1e308 overflows the sums)
        bad |= (numbers < 0) | (numbers != np.floor(numbers)) | (numbers > MAX_COUNT)
    return numbers, int(np.flatnonzero(bad)[0]) if bad.any() else None


def _unique(path: Path, table: pd.DataFrame, keys: list[str]) -> None:
    repeated = table.duplicated(keys)
    if repeated.any():
        row = int(np.flatnonzero(repeated.to_numpy())[0])
        what = ", ".join(str(table[key].iloc[row]) for key in keys)
        raise InputError(path, f"{what} appears twice", line=row + 2)


# ---- consistency ------------------------------------------------------------------------------

def _threshold(text: str, path: Path, line: int) -> Decimal:
    try:
        value = Decimal(text.strip())
    except InvalidOperation:
        value = Decimal("NaN")
    if not value.is_finite() or not 0 <= value < 1:
        raise InputError(path, f"threshold {text!r} is not an IoU threshold in [0, 1)", line=line)
    return value


def _check_accuracy(path: Path, accuracy: pd.DataFrame) -> tuple[tuple[str, ...], tuple[Decimal, ...]]:
    """Every method at every threshold exactly once, accuracy = n_tp / n_gt; returns (methods, grid)."""
    if accuracy.empty:
        raise InputError(path, "holds no rows")
    decimals = [_threshold(text, path, row + 2) for row, text in enumerate(accuracy["threshold"])]
    accuracy["threshold"] = np.array(decimals, dtype=object)
    for row, method in enumerate(accuracy["method"]):
        if not method.strip():
            raise InputError(path, "a method name is empty", line=row + 2)
    _unique(path, accuracy, ["method", "threshold"])
    methods = tuple(dict.fromkeys(accuracy["method"]))
    grid = tuple(dict.fromkeys(decimals))
    if len(accuracy) != len(methods) * len(grid):
        for method in methods:
            have = set(accuracy.loc[accuracy["method"] == method, "threshold"])
            absent = [t for t in grid if t not in have]
            if absent:
                raise InputError(path, f"method {method} has no row for threshold {absent[0]}")
    n_tp, n_gt, value = (accuracy[c].to_numpy() for c in ("n_tp", "n_gt", "accuracy"))
    bad = (n_tp > n_gt) | (np.isnan(value) & (n_gt > 0))  # NaN only where there is nothing to count
    with np.errstate(invalid="ignore", divide="ignore"):
        bad |= (n_gt > 0) & (np.abs(n_tp / np.where(n_gt > 0, n_gt, 1) - value) > 1e-6)
    if bad.any():
        row = int(np.flatnonzero(bad)[0])
        raise InputError(path, f"accuracy {value[row]:g} is not n_tp / n_gt = {n_tp[row]} / {n_gt[row]}", line=row + 2)
    for method in methods:
        if len(set(accuracy.loc[accuracy["method"] == method, "n_gt"])) != 1:
            raise InputError(path, f"method {method} has different n_gt at different thresholds")
    return methods, grid


def _columns(accuracy: pd.DataFrame) -> dict:
    out: dict[tuple[str, str], dict[Decimal, float]] = {}
    methods, thresholds = accuracy["method"].to_numpy(object), accuracy["threshold"].to_numpy(object)
    for column in accuracy.columns.drop(["method", "threshold"]):
        values = accuracy[column].to_numpy(np.float64)
        for method, threshold, value in zip(methods, thresholds, values):
            out.setdefault((method, column), {})[threshold] = float(value)
    return out


def _digest(lines) -> str:
    return hashlib.sha1("\n".join(lines).encode("utf-8", "surrogatepass")).hexdigest()


def _check_per_frame(path: Path, per_frame: pd.DataFrame, accuracy: pd.DataFrame, methods: tuple[str, ...],
                     thresholds: tuple[Decimal, ...], counts: dict) -> tuple[str, str, int]:
    """per_frame.csv must be the IoUs accuracy.csv counts; returns (frames key, truth key, clips)."""
    iou = per_frame["iou"].to_numpy()
    bad = (iou < 0) | (iou > 1)
    if bad.any():
        row = int(np.flatnonzero(bad)[0])
        raise InputError(path, f"IoU {iou[row]:g} is outside [0, 1]", line=row + 2)
    _unique(path, per_frame, ["frame", "side", "method"])
    extra = set(per_frame["method"].to_numpy(object)) - set(methods)
    if extra:
        raise InputError(path, f"holds method {sorted(extra)[0]!r}, which accuracy.csv does not")
    values = np.array([float(t) for t in thresholds])
    method_of = per_frame["method"].to_numpy(object)
    keys = per_frame["frame"].to_numpy(object) + "\t" + per_frame["side"].to_numpy(object)
    first_keys: np.ndarray | None = None  # the first method's sorted lanes, which every method must share
    for method in methods:
        mine = method_of == method
        expected = accuracy[accuracy["method"] == method]
        n_gt = int(expected["n_gt"].iloc[0])
        if int(mine.sum()) != n_gt:
            raise InputError(path, f"holds {int(mine.sum())} lanes of method {method}, but accuracy.csv counts "
                                   f"n_gt = {n_gt}: the two files are not of one run")
        ordered = np.sort(iou[mine])
        tp = len(ordered) - np.searchsorted(ordered, values, side="right")  # IoU > threshold
        stated = dict(zip(expected["threshold"], expected["n_tp"]))
        for threshold, count in zip(thresholds, tp.tolist()):
            if stated[threshold] != count:
                raise InputError(path, f"gives method {method} {count} true positives at IoU > {threshold}, but "
                                       f"accuracy.csv counts {stated[threshold]}: the two files are not of one run")
        sorted_keys = np.sort(keys[mine])
        if first_keys is None:
            first_keys = sorted_keys
        elif not np.array_equal(sorted_keys, first_keys):
            raise InputError(path, f"method {method} is scored on other ground-truth lanes than {methods[0]}")
    lanes: list[str] = [] if first_keys is None else first_keys.tolist()
    frames = sorted({key.rpartition("\t")[0] for key in lanes})
    frames_key = _digest([str(counts["labelled_frames"])] + frames)
    truth_key = _digest([str(counts["gt_lanes"]), str(counts["ego_lanes"])] + lanes)
    clips = len({frame.rpartition("/")[0] for frame in frames})
    return frames_key, truth_key, clips


def _results_key(per_frame: pd.DataFrame) -> str:
    """Every IoU of every method, in no particular row order: two runs with the same key measured
    the same thing (seeds or checkpoints never do)."""
    rows = (per_frame["frame"].astype(str) + "\t" + per_frame["side"].astype(str) + "\t"
            + per_frame["method"].astype(str) + "\t" + per_frame["iou"].map(repr))
    return _digest(sorted(rows.tolist()))


def frames_of(run: Run) -> set[str]:
    """The frames a run scored (those with a ground-truth ego lane)."""
    return set(run.per_frame["frame"])
