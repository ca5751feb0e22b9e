"""The library's front door: one function per CLI command, with the same names and options.

`run` evaluates and writes a report, `score_culane` / `score_tusimple` score lane files in
the official formats, `synthesize` writes a generated dataset. The bundled fixture lives in
`roneld_eval/_fixture` and is what `run` uses when no dataset is given.
"""

from __future__ import annotations

import contextlib
import json
import os
from dataclasses import replace
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Sequence

from .version import __version__
from .benchmarks import Benchmark
from .config import EvalConfig
from .resolve import benchmark_named, benchmark_of, configured
from .errors import ConfigError, InputError, RoneldEvalError, RunInterrupted
from .lanes_io import check_folder, check_regular_file, read_text
from .limits import RUN_TABLE
from .wording import counted
from .cache import ResultCache
from . import evaluation
from .evaluation import RunPlan, RunResult
from .output import DEFAULT_OUT, INPUT_RUN_REMEDY, JOURNAL, OutputFolder, Staging, read_manifest
from .signals import interruption_name, interruptions_unwrapped, terminate_as_interrupt
from .report.tables import Protocol
from .report.write import LaneWriter, load_drawing, stage_report

FIXTURE_MAPS_FORMAT = "npz"


def fixture_roots(dataset: str | Benchmark) -> tuple[Path, Path]:
    """(data root, maps root) of the bundled fixture of a dataset (a benchmark, or its name)."""
    benchmark = benchmark_of(dataset)
    folder = benchmark.fixture
    if folder is None:
        raise ConfigError(f"{benchmark.display_name} has no bundled fixture: give --data-root and --maps-root")
    base = Path(str(resources.files("roneld_eval._fixture"))) / folder
    data, maps = base / "data", base / "maps"
    if not data.is_dir() or not maps.is_dir():
        raise InputError(base, "the bundled fixture is missing from this installation")
    return data, maps


def default_config(dataset: str | None = None) -> EvalConfig:
    """The preset of a dataset's default model (SCNN); without one, the fixture's benchmark."""
    from .benchmarks import default_name

    benchmark = benchmark_named(dataset or default_name())
    if benchmark.default_preset is None:
        raise ConfigError(f"{benchmark.display_name} is scored from lane files only: "
                          f"`roneld-eval score {benchmark.name}`")
    preset = EvalConfig.from_toml(benchmark.default_preset)
    if preset.dataset.name not in ("", benchmark.name):  # a benchmark's copied preset, not renamed
        raise ConfigError(f"benchmark {benchmark.name!r}: its default preset ({benchmark.default_preset}) is for "
                          f"dataset {preset.dataset.name!r}, not for it")
    # A preset name or a file; not the user's file, so what is wrong later is not said to be in it
    # (`--set dataset.name=foo` is no fault of scnn-culane.toml).
    return replace(preset, source=None)


def with_fixture(config: EvalConfig, benchmark: Benchmark | None = None) -> EvalConfig:
    """The configuration pointed at the bundled fixture (of `benchmark`, else of the benchmark it
    names) when it names no data."""
    if config.dataset.data_root is not None or config.maps.root is not None:
        return config
    data, maps = fixture_roots(benchmark or configured(config)[1])
    return config.with_overrides(**{"dataset.data_root": str(data), "maps.root": str(maps),
                                    "maps.format": FIXTURE_MAPS_FORMAT})


def with_absolute_paths(config: EvalConfig) -> EvalConfig:
    """The configuration with every path made absolute, so its config.toml works from anywhere."""
    def absolute(value: str | None) -> str | None:
        return None if value is None else os.path.abspath(os.path.expanduser(value))

    config = config.with_overrides(**{
        "dataset.data_root": absolute(config.dataset.data_root),
        "maps.root": absolute(config.maps.root),
        "dataset.list_file": absolute(config.dataset.list_file),
    })
    plugins = []
    for plugin in config.plugins:
        where, _, attribute = plugin.entry.rpartition(":")
        if where.endswith(".py"):  # a plug-in file, as a path
            plugin = replace(plugin, entry=f"{absolute(where)}:{attribute}")
        plugins.append(plugin)
    return replace(config, plugins=tuple(plugins)) if plugins else config


def run(config: EvalConfig | None = None, out: str | Path = DEFAULT_OUT, progress: bool = True,
        resume: bool = False, overlays: int = 0, announce: Callable[[str], None] | None = None,
        shard: str | None = None, timings: bool = True, diagnose: bool = False,
        loc_iou: float | None = None) -> RunResult | None:
    """Evaluate every configured method and write the report to `out` (see the README).

    Finished clips are kept in `out` while the run goes on; after an interruption,
    `resume=True` evaluates only the clips not yet finished and gives the same numbers.
    `overlays=N` also draws the N frames where the baseline and RONELD differ most.
    `announce` receives one-line notes (the geometry used, what resume reused).
    The folder `out` is the run's own: see roneld_eval.output. With `shard` ('I/N') only that
    share of the clips is evaluated and `out` gets its part for `merge` (None is returned).
    `timings=False` leaves what the clock measured out of the report (RunResult.timed).
    `diagnose`: also why each method's official F1 is not higher (`loc_iou`, its error types, as
    `score NAME --diagnose` gives them): the lanes are saved (as `save_lanes`) and scored so.
    """
    requested, benchmark = configured(with_absolute_paths(config or default_config()))
    if diagnose or loc_iou is not None:
        requested = diagnosable(requested, benchmark, diagnose, loc_iou, shard)
    config = with_fixture(requested, benchmark)
    say = announce or (lambda message: None)
    if shard is not None:
        from .shards import parse_shard

        if resume or overlays or not timings:
            raise ConfigError("--shard writes a part for `roneld-eval merge`, not a report: without --resume, "
                              "--overlays (draw pictures of the merged run with `roneld-eval show`) or --no-timings")
        _run_shard(config, benchmark, requested, parse_shard(shard), out, progress, say)
        return None
    with terminate_as_interrupt(), OutputFolder(out, "run", nested={SHOW_FOLDER: "show"}) as folder:
        staging = Staging(folder)
        cache = ResultCache(folder.path, config, benchmark, __version__, resume, note=say)
        with _kept_for_resume(cache):
            writer = LaneWriter(staging, benchmark) if config.save_lanes else None
            result = _evaluated(config, benchmark, requested, staging, writer, cache, progress, resume, say)
            if overlays:
                _stage_pictures(staging, config, result, overlays)
            if diagnose:
                assert writer is not None
                result.diagnosed = _stage_diagnosis(staging, benchmark, config, result, list(writer.frames), loc_iou,
                                                    say)
            result.timed = timings
            stage_report(result, staging)
            folder.commit(then=cache.discard)  # a signal meanwhile waits, then says the results are complete
    return result


@contextlib.contextmanager
def _kept_for_resume(cache: ResultCache):
    """Finished clips stay in the cache for --resume when the run is interrupted (a worker died,
    Ctrl-C, SIGTERM or SIGHUP, evaluating or writing the report), and go on any other failure."""
    try:
        with interruptions_unwrapped():  # one that C code swallowed and replaced is still one
            yield
    except RunInterrupted:
        raise
    except KeyboardInterrupt as error:
        reason, code = interruption_name(error)
        raise RunInterrupted(_unfinished(reason, cache), exit_code=code) from None
    except BaseException:
        cache.discard()  # bad input or a bug: nothing to resume from
        raise


def _run_diagnosis(benchmark) -> Callable[..., Any] | None:
    """A benchmark's `diagnose_run` (the lanes a run saved, scored with --diagnose), where it has one:
    its official metric matches lanes by IoU."""
    return getattr(benchmark, "diagnose_run", None)


def diagnosable(config: EvalConfig, benchmark: Benchmark, diagnose: bool, loc_iou: float | None,
                 shard: str | None) -> EvalConfig:
    """The configuration `run --diagnose` evaluates (its lanes saved: what it scores); a
    ConfigError where the options or the benchmark do not allow it, before any work."""
    from .metrics.lane_errors import diagnosis_settings

    diagnosis_settings(diagnose, loc_iou, None, ())  # --loc-iou alone, or outside (0, 1]
    if _run_diagnosis(benchmark) is None:
        raise ConfigError(f"--diagnose: {benchmark.display_name}'s official metric does not match lanes by IoU, so "
                          "its errors have no types; save the lanes (--save-lanes) and see `roneld-eval score "
                          f"{benchmark.name} --help` for what it says of each frame")
    if shard is not None:
        raise ConfigError("--diagnose writes a report, which a shard does not: run the shards with --save-lanes, "
                          f"merge them, and score the merged lanes with `roneld-eval score {benchmark.name} "
                          "--diagnose`")
    return config.with_overrides(save_lanes=True)


def _stage_diagnosis(staging: Staging, benchmark: Benchmark, config: EvalConfig, result: RunResult,
                     frames: Sequence[str], loc_iou: float | None, say: Callable[[str], None]):
    """errors.csv/.md/.png, frames.csv.gz, gallery.json and the gallery drawn (gallery/, gallery.png)
    of the lanes the run staged, scored with its benchmark's --diagnose over the frames it scored."""
    from .metrics.lane_iou_f1 import highlighted
    from .report.diagnosis import write_diagnosis
    from .report.tables import display_name
    from .report.gallery import read_gallery, stage_gallery

    diagnose_run = _run_diagnosis(benchmark)
    assert diagnose_run is not None  # diagnosable refused the run without it
    diagnosed = diagnose_run(staging.path / "lanes", result.dataset, frames, config, loc_iou, say)
    # named in its tables and figures as the run's own tables name the methods
    diagnosed = replace(diagnosed, display={method: display_name(method, config.model) for method in config.methods})
    write_diagnosis(staging, diagnosed, highlighted(diagnosed.labels))
    if (staging.path / "gallery.json").is_file():
        record = read_gallery(staging.path)
        root = record.get("image_root")
        stage_gallery(staging, record, Path(root) if root else None, 1)
    return diagnosed


def _evaluated(config: EvalConfig, benchmark: Benchmark, requested: EvalConfig, staging: Staging,
               writer: LaneWriter | None, cache: ResultCache, progress: bool, resume: bool,
               say: Callable[[str], None]) -> RunResult:
    """The run's result, its lanes staged by `writer` (with save_lanes); it must have scored a frame."""
    try:
        result = evaluation.evaluate(config, benchmark, progress=progress, lane_sink=writer, cache=cache, announce=say,
                          meanwhile=load_drawing)
    except RunInterrupted as error:  # a worker died: say what is kept for --resume
        raise RunInterrupted(_unfinished(str(error), cache), exit_code=error.exit_code) from None
    if resume:
        say(f"resume: {cache.summary()}")
    if not result.counts["labelled_frames"]:
        raise InputError(config.maps.root or config.dataset.data_root,
                         _nothing_scored(result.counts["clips"], result.skipped))
    if writer is not None:
        writer.close()
    if config is not requested:
        # Record the bundled fixture by name, not by this machine's paths, so the written
        # config.toml reruns anywhere.
        result.config = requested
        result.fixture = config.dataset.name
    return result


def _stage_pictures(staging: Staging, config: EvalConfig, result: RunResult, overlays: int) -> None:
    """The `overlays` frames where the methods differ most, drawn."""
    from .report.overlays import worst_frames
    from .report.pictures import frame_pictures
    from .report.write import write_pictures

    chosen = worst_frames(result.per_frame, overlays)
    protocol = Protocol.of_run(result).paper_short()
    pictures = frame_pictures(config, result.benchmark, result.dataset, chosen, list(config.methods), protocol)
    write_pictures(staging, pictures)


def _run_shard(config: EvalConfig, benchmark: Benchmark, requested: EvalConfig, shard, out: str | Path,
               progress: bool, say: Callable[[str], None]) -> None:
    """One shard of a run: its clips evaluated and kept as a part (roneld_eval.run_parts), with
    the configuration as requested (the bundled fixture by name), as a run's config.toml."""
    from .run_parts import PartWriter, write_run_part

    with terminate_as_interrupt(), OutputFolder(out, "run") as folder:
        staging = Staging(folder)
        writer = PartWriter(staging)
        result = evaluation.evaluate(config, benchmark, progress=progress, cache=writer, announce=say, shard=shard)
        write_run_part(staging, config, requested, shard, result.dataset, writer, __version__,
                       result.wall_time_s)
        folder.commit()


def merge_run(parts, out: str | Path) -> RunResult:
    """The run the parts are shards of, written to `out` as that run writes it; every clip's
    results come from the parts (run_parts.PartsCache), none is computed again."""
    from .run_parts import CONFIG, PartsCache, ground_truth, shards_wall_time

    from .lanes_io import decode_text
    from .limits import CONFIG as CONFIG_SIZE

    config_path = parts[0].path / CONFIG
    requested, benchmark = configured(EvalConfig.from_toml_text(
        decode_text(parts[0].read(CONFIG, CONFIG_SIZE), config_path), source=str(config_path)))
    config = with_fixture(requested, benchmark)
    if config.plugins:  # a part is untrusted: merging it must not import code it names
        raise InputError(parts[0].path / CONFIG, "names plug-in methods; merge imports no code a part names: "
                                                 "run the whole evaluation unsharded, or merge without the plug-ins")
    from .cache import config_key

    if config_key(config, __version__) != parts[0].manifest["settings"]:
        raise InputError(parts[0].path / CONFIG, "not the configuration its part.json was run with (or a plug-in's "
                                                 "code changed since)")
    cache = PartsCache(parts, config, benchmark)
    with terminate_as_interrupt(), OutputFolder(out, "run", nested={SHOW_FOLDER: "show"}) as folder:
        staging = Staging(folder)
        writer = LaneWriter(staging, benchmark) if config.save_lanes else None
        result = evaluation.evaluate(config, benchmark, progress=False, lane_sink=writer, cache=cache)
        if ground_truth(result.dataset) != parts[0].manifest["ground_truth"]:
            raise InputError(config.dataset.data_root, "the dataset's clips or categories are not those the shards "
                                                       "were run on")
        if cache.unused():
            raise InputError(parts[0].path, f"clip {cache.unused()[0]} of a part is not among the clips the run "
                                            "evaluates now (left out, or no longer listed)")
        if not result.counts["labelled_frames"]:
            raise InputError(config.maps.root or config.dataset.data_root,
                             _nothing_scored(result.counts["clips"], result.skipped))
        if writer is not None:
            writer.close()
        if config is not requested:  # the bundled fixture, recorded by name as the run records it
            result.config = requested
            result.fixture = config.dataset.name
        result.wall_time_s = shards_wall_time(parts)
        result.notes.append(f"merged from {len(parts)} shards: the wall time is the sum of theirs, the timings "
                            "each shard's own")
        stage_report(result, staging)
        folder.commit()
    return result


def evaluate(config: EvalConfig, progress: bool = True, **options) -> RunResult:
    """Evaluate every configured method on the dataset's stored maps and return the result,
    writing nothing (the library `run` without its report; options as evaluation.evaluate's)."""
    config, benchmark = configured(config)
    return evaluation.evaluate(config, benchmark, progress=progress, **options)


def read_dataset(dataset: str | Benchmark, root: str | Path, list_file: str | Path | None = None,
                 limit: int | None = None, errors: list | None = None, labels: bool = True):
    """A registered benchmark's dataset under `root` (the benchmark, or its name), clips in order;
    see roneld_eval.datasets.read_dataset."""
    from . import datasets

    benchmark = benchmark_of(dataset)
    return datasets.read_dataset(benchmark, root, list_file, limit, errors, labels)


def plan_run(config: EvalConfig | None = None, announce: Callable[[str], None] | None = None,
             diagnose: bool = False, loc_iou: float | None = None) -> RunPlan:
    """What `run` would evaluate, checked as a run checks it before any work, without
    evaluating or writing anything (`run --dry-run`): the layout, every frame's maps, the
    first map's geometry, and `diagnose` and `loc_iou` as `run` takes them. A first map that
    cannot be read is the error the run would stop with (under on_error = "fail"): a dry run
    said all was well where the run then failed."""
    requested, benchmark = configured(with_absolute_paths(config or default_config()))
    planned = evaluation.plan(with_fixture(requested, benchmark), benchmark, announce=announce)
    if diagnose or loc_iou is not None:
        diagnosable(planned.context.config, planned.context.benchmark, diagnose, loc_iou, None)
    if planned.geometry is None and planned.clips and planned.context.config.on_error == "fail":
        planned.context.load(planned.clips[0].frames[0])  # raises what is wrong with it
    return planned


def _nothing_scored(clips: int, skipped: list[str]) -> str:
    """Why a run that scored no frame writes no result (tables of n/a would read as results)."""
    if skipped:
        return (f"nothing was scored: every labelled frame was skipped ({len(skipped):,} skipped, first: "
                f"{skipped[0]}); no result was written")
    return f"nothing was scored: {counted(clips, 'clip')} and no labelled frame; no result was written"


def _unfinished(reason: str, cache: ResultCache) -> str:
    done = cache.count()
    if not done:
        cache.discard()  # an empty cache folder would only be clutter
    kept = (f"{done} finished clip{'s' if done != 1 else ''} kept in {cache.folder}; run the same command "
            f"with --resume to continue") if done else "nothing to resume from"
    return f"{reason}: no result was written; {kept}"


# ---- scoring lane files: benchmarks/<name>/score.py -------------------------------------------


def score(name: str, *args, **options):
    """`roneld-eval score NAME` as a function, for every registered benchmark: the options of its
    command as arguments (its library scorer's: `help(roneld_eval.benchmarks.benchmark_for(
    NAME).scorer())` lists them), returning what that scorer returns (its tables)."""
    benchmark = benchmark_of(name)
    scorer = getattr(benchmark, "scorer", None)
    if scorer is None:
        raise ConfigError(f"benchmark {name!r} offers no library scorer: run `roneld-eval score {name}`")
    return scorer()(*args, **options)


# The older names of two of them, kept (what they return is what they returned).
def score_culane(*args, **options):
    """score("culane", ...): the official CULane scores of .lines.txt trees (CulaneScore)."""
    return score("culane", *args, **options)


def score_tusimple(*args, **options):
    """score("tusimple", ...): TuSimple lane.py's scores of predictions.json files (TusimpleScore)."""
    return score("tusimple", *args, **options)


# Re-exported, loaded on first use: `run` needs none of these modules (25 ms of its start-up).
_LOADED_ON_USE = {"SynthResult": "synth", "synthesize": "synth"}


if TYPE_CHECKING:
    from .synth import SynthResult, synthesize


def __getattr__(name: str):
    if name not in _LOADED_ON_USE:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    from importlib import import_module

    return getattr(import_module(f".{_LOADED_ON_USE[name]}", __package__), name)


def __dir__() -> list[str]:  # help() and tab completion list them too
    return sorted(set(globals()) | set(_LOADED_ON_USE))


__all__ = ["run", "evaluate", "read_dataset", "show",
           "score", "score_culane", "score_tusimple", "synthesize", "fixture_roots", "default_config",
           "SynthResult"]


# ---- pictures: roneld_eval.report.pictures ----------------------------------------------------


def show(run_dir: str | Path, frames: Sequence[str] = (), worst: int | None = None, methods: Sequence[str] = (),
         out: str | Path | None = None, image_root: str | Path | None = None) -> list[Path]:
    """Draw frames of a finished run (given ones, or the `worst` N where methods differ most), or
    the gallery of a score written with --diagnose (show_gallery).

    Pictures go to `out` (default: `<run>/show/`), never over the run's own files:
    overlays/<frame>.png and the contact sheet overlays.png.
    """
    run_dir = Path(run_dir)
    from .report.gallery import is_gallery

    if is_gallery(run_dir):
        return show_gallery(run_dir, worst, out, image_root)
    check_finished_run(run_dir, "; a score's gallery needs `score ... --diagnose --out`")
    target = Path(out) if out is not None else run_dir / SHOW_FOLDER
    if target.resolve() == run_dir.resolve():
        raise InputError(target, "pictures go to their own folder, not over the run's files: choose another --out")
    # The output folder is taken before any work: a folder that cannot be used is refused at once.
    with terminate_as_interrupt(), OutputFolder(target, "show") as folder:
        pictures = _show_pictures(run_dir, frames, worst, methods)
        from .report.write import write_pictures

        write_pictures(Staging(folder), pictures)
        return folder.commit()


def show_gallery(score_dir: Path, worst: int | None = None, out: str | Path | None = None,
                 image_root: str | Path | None = None) -> list[Path]:
    """The gallery of a score written with --diagnose (its gallery.json): for each method, the
    `worst` frames (default 3) with most errors in each category and most of each error type,
    ground truth and every method's lanes over the image (`image_root`, default the one the
    score read; a blank canvas of the frame's size without one): gallery/<k>.png and gallery.png,
    and report.html with the score's error table, its score sweep and the gallery."""
    from .report.gallery import GALLERY_FRAMES, read_gallery, stage_gallery

    if image_root is not None and not Path(image_root).is_dir():
        raise InputError(Path(image_root), "not a folder: give the folder the frames' images are under")
    if worst is not None and worst > GALLERY_FRAMES:
        raise ConfigError(f"--worst {worst}: a score's gallery keeps {GALLERY_FRAMES} frames a reason")
    record = read_gallery(score_dir)
    target = Path(out) if out is not None else score_dir / SHOW_FOLDER
    if target.resolve() == score_dir.resolve():
        raise InputError(target, "pictures go to their own folder, not over the score's files: choose another --out")
    root = image_root if image_root is not None else record.get("image_root")
    with terminate_as_interrupt(), OutputFolder(target, "show") as folder:
        staging = Staging(folder)
        stage_gallery(staging, record, Path(root) if root else None, worst or 3)
        from .report.html import build_diagnosis_html

        staging.write_text("report.html", build_diagnosis_html(
            score_dir, staging.path, f"roneld-eval: why F1 is not higher, {record['title']}", worst or 3))
        return folder.commit()


def _show_pictures(run_dir: Path, frames: Sequence[str], worst: int | None, methods: Sequence[str]):
    requested, benchmark = configured(EvalConfig.from_toml(run_dir / "config.toml"))
    config = with_fixture(requested, benchmark)
    check_regular_file(run_dir / "per_frame.csv", "missing from this run folder", RUN_TABLE)
    import pandas as pd

    try:
        per_frame = pd.read_csv(run_dir / "per_frame.csv")
    except (OSError, ValueError, pd.errors.ParserError) as error:
        raise InputError(run_dir / "per_frame.csv", f"cannot read: {error}") from None
    if list(per_frame.columns) != ["frame", "side", "method", "iou"]:
        raise InputError(run_dir / "per_frame.csv",
                         "not a per-frame table of this tool (columns frame, side, method, iou)")
    chosen = list(frames)
    if worst or not chosen:
        from .report.overlays import worst_frames

        chosen += worst_frames(per_frame, worst or 6)
    if config.dataset.data_root is None:  # a run needs one, so its config.toml was edited since
        raise InputError(run_dir / "config.toml", "names no dataset.data_root, so the frames cannot be found")
    dataset = read_dataset(benchmark, config.dataset.data_root, config.dataset.list_file, config.dataset.limit)
    try:
        recorded = Protocol.from_summary(json.loads(read_text(run_dir / "summary.json")))
    except (RoneldEvalError, ValueError, AttributeError, TypeError, RecursionError):
        recorded = None
    from .report.pictures import frame_pictures

    return frame_pictures(config, benchmark, dataset, chosen, methods, recorded.paper_short() if recorded else "")


SHOW_FOLDER = "show"


def check_finished_run(run_dir: Path, other_kinds: str = "") -> None:
    """Stop unless `run_dir` holds the complete results of `roneld-eval run`; `other_kinds`
    says what else the reader takes, where another command wrote the folder."""
    check_folder(run_dir, "not found", ": give a folder written by `roneld-eval run`")
    if os.path.lexists(run_dir / JOURNAL):  # also a first commit cut short, before any manifest
        raise InputError(run_dir, "its results are incomplete (a command was killed while putting them in "
                                  "place); run it again into this folder")
    manifest = read_manifest(run_dir, INPUT_RUN_REMEDY)
    if manifest is None:
        raise InputError(run_dir, "not a folder written by `roneld-eval run` (it has no run manifest)")
    if manifest["command"] != "run":
        raise InputError(run_dir, f"not a folder written by `roneld-eval run` (`roneld-eval {manifest['command']}` "
                                  f"wrote it){other_kinds}")
    for name in ("config.toml", "per_frame.csv"):
        if name not in manifest["entries"]:
            raise InputError(run_dir / name, "missing from this run folder")
        check_regular_file(run_dir / name, "missing from this run folder")  # a FIFO or a device named so
