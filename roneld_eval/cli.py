"""The `roneld-eval` command: options in, one library call, our errors out as one line (exit 2).

Nothing here computes anything; see api.py for the functions each command calls.
"""

from __future__ import annotations

import atexit
import gc
import sys
import traceback
from dataclasses import replace
from pathlib import Path
from typing import NoReturn

import click

from .version import __version__
from .wording import counted
from .benchmarks import names as benchmark_names, origin as benchmark_origin
from .config import FRAMES_PER_DEFAULT_WORKER, LANES_MODEL, METHODS, EvalConfig, map_formats, parse_setting
from .presets import is_preset, preset_names
from .errors import ConfigError, RoneldEvalError
from .limits import check_environment
from .output import DEFAULT_OUT
from .cluster import executed


class UsageProblem(click.ClickException):
    """A RoneldEvalError as click shows it: 'error: <path>:<line>: <problem>', exit status 2."""

    exit_code = 2

    def __init__(self, message: str, exit_code: int = 2):
        super().__init__(message)
        # click reads e.exit_code from the instance; its annotation (ClassVar) allows only a class value
        self.exit_code = exit_code  # type: ignore[misc]

    def show(self, file=None):
        click.echo(f"error: {self.message}", err=True)


def _fail(error: BaseException, debug: bool):
    if debug:
        traceback.print_exception(error)
    raise UsageProblem(str(error), getattr(error, "exit_code", 2)) from None


def _check_path_text(value) -> None:
    """A folder, file or name given on the command line must be text the files written can hold
    (a non-UTF-8 name otherwise fails only when the path is recorded, after all the work)."""
    if isinstance(value, (list, tuple)):
        for item in value:
            _check_path_text(item)
    elif isinstance(value, (str, Path)):
        try:
            str(value).encode("utf-8")
        except UnicodeEncodeError:
            raise ConfigError(f"{str(value)!a} is not valid Unicode text (a name that is not UTF-8); rename it, "
                              "or run under a UTF-8 locale such as LC_ALL=C.UTF-8") from None


def _guard(function, debug: bool, *args, **kwargs):
    """Call the library; bad input becomes one line and exit 2, Ctrl-C a short note and 130."""
    from .output import commits_so_far
    from .signals import interruptions_unwrapped

    commits = commits_so_far()
    try:
        for value in (*args, *kwargs.values()):
            _check_path_text(value)
        check_environment()
        with interruptions_unwrapped():  # Ctrl-C inside a numba kernel or an import is Ctrl-C
            return function(*args, **kwargs)
    except RoneldEvalError as error:
        _fail(error, debug)
    except KeyboardInterrupt as error:
        complete = commits_so_far() > commits  # on the way back from a commit: not "nothing written"
        _interrupted(error, ": the results are complete" if complete else ": no result was written")
    except MemoryError:
        _fail(RoneldEvalError("out of memory (try fewer --workers)"), debug)
    except OSError as error:
        where = getattr(error, "filename", None)
        message = f"{where}: {error.strerror}" if where else str(error)
        _fail(RoneldEvalError(message), debug)


def _interrupted(error: KeyboardInterrupt, said: str = "") -> NoReturn:
    """'interrupted' or 'terminated (SIGTERM)' and what it means, then exit 130 or 128 + n."""
    from .signals import interruption_name

    reason, code = interruption_name(error)
    click.echo(f"{reason}{said}", err=True)
    sys.exit(code)


def _no_collections_at_exit() -> None:
    """When the process ends, its last garbage collections would walk numba's, pandas' and
    matplotlib's objects, none of them garbage: 0.2-0.3 s of every command (scripts/bench_startup.py).
    Frozen at exit, they are skipped."""
    atexit.unregister(gc.freeze)  # registered once, however often a command runs in one process
    atexit.register(gc.freeze)


def _dry_run(config: EvalConfig, quiet: bool, debug: bool, diagnose: bool, loc_iou: float | None) -> None:
    from . import api

    planned = _guard(api.plan_run, debug, config, announce=_announcer(quiet), diagnose=diagnose, loc_iou=loc_iou)
    frames = sum(len(clip.frames) for clip in planned.clips)
    labelled = sum(frame.labelled for clip in planned.clips for frame in clip.frames)
    click.echo(f"dry run: {planned.dataset.name}, {counted(len(planned.clips), 'clip')}, {counted(frames, 'frame')} "
               f"({labelled} labelled, scored) with {', '.join(planned.context.config.methods)}; maps "
               f"{planned.context.config.maps.format} in {planned.context.maps_root}; nothing evaluated or written")
    for line in planned.skipped:
        click.echo(f"  would skip: {line}")
    if not labelled:
        _fail(RoneldEvalError("nothing would be scored: no clip with all its maps holds a labelled frame"), debug)


def _announcer(quiet: bool):
    """Where the library's one-line notes go: stderr, unless --quiet."""
    return None if quiet else (lambda message: click.echo(message, err=True))


debug_option = click.option("--debug", is_flag=True, help="Show the full traceback of an error.")


class _Folder(click.Path):
    """An output folder. Empty is refused: as a path it is the current folder, where an unset
    shell variable (--out "$OUT") would write the results without a word."""

    def convert(self, value, param, ctx):
        if isinstance(value, str) and not value.strip():
            self.fail("is empty: name a folder (write . for the current one)", param, ctx)
        return super().convert(value, param, ctx)


OUT_FOLDER = _Folder(path_type=Path)


class MapFormatChoice(click.Choice):
    """The registered maps formats, read when first asked for (a command's --help or value), not
    when the command line is built: their names come from the installed packages' metadata."""

    def __init__(self) -> None:
        super().__init__(())

    @property
    def choices(self):
        return map_formats()

    @choices.setter
    def choices(self, value) -> None:
        pass


def sharding_options(clips: str, verb: str = "Score"):
    """--shard, --executor and --scheduler; `clips` says what a command's whole units are."""
    def decorate(function):
        for option in reversed((
            click.option("--shard", metavar="I/N",
                         help=f"{verb} only shard I of N (whole {clips}, in list order) and write its part to --out; "
                              "`roneld-eval merge` turns the N parts into this command's files."),
            click.option("--executor", type=click.Choice(("local", "dask")), default="local", show_default=True,
                         help="dask: run the command as shards on a dask.distributed cluster (one a worker thread) "
                              "and merge them into --out, the same files as here; the inputs must be at the same "
                              "paths on its workers (pip install 'roneld-eval[cluster]')."),
            click.option("--scheduler", metavar="ADDRESS",
                         help="With --executor dask: a running scheduler (tcp://HOST:8786). Default: a local cluster "
                              "started for this command, of --workers processes where the command has --workers, "
                              "else of one a core."),
        )):
            function = option(function)
        return function
    return decorate


class _Command(click.Group):
    """The command group, with SIGTERM and SIGHUP ending any command as Ctrl-C does from the
    moment click starts, and Ctrl-C outside a command's own handling one line and 128 + n,
    not click's "Aborted!" and exit 1 (nor a process killed without a word)."""

    def main(self, *args, **kwargs):
        from .signals import terminate_as_interrupt

        try:
            with terminate_as_interrupt():
                super().main(*args, **{**kwargs, "standalone_mode": False})
            sys.exit(0)  # as click's standalone mode ends: never a command's return value as the status
        except (click.exceptions.Abort, KeyboardInterrupt) as stop:  # click wraps Ctrl-C in Abort
            cause = stop.__cause__ if isinstance(stop, click.exceptions.Abort) else stop
            _interrupted(cause if isinstance(cause, KeyboardInterrupt) else KeyboardInterrupt())
        except click.exceptions.Exit as done:  # --help, --version
            sys.exit(done.exit_code)
        except click.UsageError as error:
            if isinstance(error, getattr(click.exceptions, "NoArgsIsHelpError", ())):  # bare `roneld-eval`: the help
                error.show()
                sys.exit(error.exit_code)
            # One line, as every other error: click's own took three or more (usage, a hint, and
            # the choices of a --dataset one per line).
            where = self._command_path(args[0] if args else kwargs.get("args"), kwargs.get("prog_name"))
            click.echo(f"error: {' '.join(error.format_message().split())} (see {where} --help)", err=True)
            sys.exit(error.exit_code)
        except click.ClickException as error:
            error.show()
            sys.exit(error.exit_code)

    def _command_path(self, args, prog_name) -> str:
        """'roneld-eval score culane' from the command line's leading command names: an option
        missing its value was raised with its parent group's context, or none."""
        words = [prog_name or "roneld-eval"]
        command: click.Command = self
        for arg in (sys.argv[1:] if args is None else list(args)):
            found = command.get_command(click.Context(command), arg) if isinstance(command, click.Group) else None
            if found is None:
                break
            words.append(arg)
            command = found
        return " ".join(words)


@click.group(cls=_Command, context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 100})
@click.version_option(__version__, prog_name="roneld-eval")
def main():
    """Evaluate lane detectors and RONELD on the lane benchmarks, exactly as their official tools do.

    `run` runs the SCNN/ENet-SAD baseline and RONELD on a model's stored probability maps (or
    another detector's lane files) and reports the RONELD paper's active-lane accuracy, each
    benchmark's official scores and runtime; `score BENCHMARK` scores lane files with a
    benchmark's official metric (`roneld-eval score --help` lists the benchmarks installed).
    With no arguments, `roneld-eval run` evaluates the bundled fixture.
    """


def _given_config(config_file: str | None, dataset: str | None, settings: tuple[str, ...] = ()) -> EvalConfig:
    """The configuration `--config` names (a file or preset), else `--dataset`'s default; the two
    must not name different datasets. A file's settings are read over the preset of the dataset
    the run will score (`--set dataset.name`'s, --dataset's or the file's), so that what it leaves
    out is that dataset's, not the dataclasses' defaults (SCNN's on CULane)."""
    from .api import default_config

    if config_file is None:
        return default_config(dataset)
    from .benchmarks import default_name, names
    from .resolve import benchmark_named, configured

    config = EvalConfig.from_toml(config_file)
    if dataset is not None and config.dataset.name and dataset != config.dataset.name:
        raise ConfigError(f"--dataset {dataset} contradicts the config's dataset {config.dataset.name}")
    chosen = _set_dataset(settings) or dataset or config.dataset.name or default_name()
    preset = benchmark_named(chosen).default_preset if chosen in names() else None
    if preset is not None:
        config = EvalConfig.from_toml_over(config_file, preset)
    if dataset is not None:
        config = config.with_overrides(**{"dataset.name": dataset})
    configured(config)  # what the file lacks or contradicts of its benchmark, said naming it
    # Left unfilled (and no longer naming the file): --set may still change the benchmark, and
    # a problem of the options given is not the file's.
    return replace(config, source=None)


def _set_dataset(settings: tuple[str, ...]) -> str | None:
    """The dataset `--set dataset.name=NAME` chooses (the last such setting), if any."""
    chosen = None
    for setting in settings:
        key, value = parse_setting(setting)
        if key == "dataset.name" and isinstance(value, str):
            chosen = value
    return chosen


@main.command()
@click.option("--config", "config_file", metavar="FILE|PRESET",
              help=f"Configuration TOML file or preset name ({', '.join(preset_names())}). "
                   "Default: the dataset's preset (SCNN's, where there is one). A file that gives only some "
                   "settings takes the others from its dataset's preset.")
@click.option("--dataset", type=click.Choice(benchmark_names()),
              help="Benchmark layout of --data-root. Default: the config's, else the bundled fixture's.")
@click.option("--data-root", type=click.Path(path_type=Path),
              help="Dataset root (CULane: holds list/test.txt; TuSimple: holds test_label.json; VIL-100: holds "
                   "anno_txt/ and JPEGImages/, Json/ or sizes.json). Without it and --maps-root, the bundled "
                   "fixture is evaluated.")
@click.option("--maps-root", type=click.Path(path_type=Path),
              help="Folder of stored maps mirroring the dataset tree (<rel>/00000.npy for <rel>/00000.jpg).")
@click.option("--maps-format", type=MapFormatChoice(),
              help="How maps are stored: .npy, .npz, or SCNN's <frame>_<k>_avg.png + .exist.txt; or 'lanes': "
                   "another detector's lane files (CULane .lines.txt mirrored under --maps-root, or TuSimple "
                   "predictions.json in it), drawn into maps for RONELD; 'baseline' is then the detector's own lanes.")
@click.option("--list", "list_file", type=click.Path(path_type=Path),
              help="CULane list file (default <data-root>/list/test.txt), TuSimple label file "
                   "(default <data-root>/test_label.json) or VIL-100 list (default <data-root>/data/test.txt, "
                   "else every labelled frame).")
@click.option("--methods", help=f"Comma-separated methods among {', '.join(METHODS)} and plug-ins. "
                                "Default: baseline,roneld.")
@click.option("--method", "plugins", multiple=True, metavar="NAME=MODULE:CALLABLE",
              help="Also run your own extractor as method NAME: a factory in an importable module (or "
                   "path/to/file.py:callable), see README 'Your own extractor' (repeatable).")
@click.option("--pft-ablation", is_flag=True, default=None,
              help="Also run RONELD without preceding-frame tracking and write the ablation table.")
@click.option("--no-pft", is_flag=True, help="Run RONELD itself without preceding-frame tracking.")
@click.option("--thresholds", metavar="START:STOP:STEP",
              help="IoU thresholds of the accuracy sweep, inclusive. Default: 0.30:0.50:0.01.")
@click.option("--workers", type=click.IntRange(min=1),
              help="Worker processes (clips run in parallel). Default: all cores, at most one per "
                   f"{FRAMES_PER_DEFAULT_WORKER} frames.")
@click.option("--limit", type=click.IntRange(min=1), help="Evaluate only the first N clips.")
@click.option("--save-lanes", is_flag=True, default=None,
              help="Also write every method's lanes in the official formats under OUT/lanes/.")
@click.option("--set", "settings", multiple=True, metavar="SECTION.KEY=VALUE",
              help="Override any configuration value, e.g. --set paper.thickness_rule=height (repeatable).")
@click.option("--overlays", type=click.IntRange(min=0), default=0,
              help="Also draw the N frames where the baseline and RONELD differ most (overlays/, overlays.png).")
@click.option("--diagnose", is_flag=True,
              help="Also say why each method's official F1 is not higher: its lanes (saved, as --save-lanes) scored "
                   "as `score NAME --diagnose` scores them, each false positive and false negative as an error type "
                   "(errors.csv/.md/.png), every frame's counts (frames.csv.gz) and the worst frames drawn (gallery/, "
                   "gallery.png), all in report.html. On the benchmarks whose official metric matches lanes by IoU.")
@click.option("--loc-iou", type=float, metavar="IOU",
              help="With --diagnose: a false positive whose IoU with its ground-truth lane is at least this is a "
                   "localisation error (Loc), below it background (Bkg). Default: 0.1.")
@click.option("--on-error", type=click.Choice(["fail", "skip"]),
              help="On a bad frame, label or clip: stop with an error (default), or skip it and list it in "
                   "summary.json and on screen.")
@click.option("--resume", is_flag=True,
              help="Continue an interrupted run into the same --out: reuse its finished clips (same numbers).")
@click.option("--dry-run", is_flag=True,
              help="Only check the dataset's layout and every frame's maps, and say what would be scored and "
                   "at which geometry; evaluate and write nothing (exit 0, or 2 with the problem).")
@click.option("--out", type=OUT_FOLDER, default=Path(DEFAULT_OUT), show_default=True,
              help="Folder for the results; git ignores the default in this repository. A folder of earlier "
                   "results given here (results/ too) is replaced.")
@sharding_options("clips", verb="Evaluate")
@click.option("--no-timings", is_flag=True,
              help="Leave what the clock measures (runtime per frame, wall time) out of the report, so that running "
                   "again writes the same bytes (how results/ is written).")
@click.option("--quiet", is_flag=True, help="No progress bar or summary table.")
@debug_option
def run(config_file, dataset, data_root, maps_root, maps_format, list_file, methods, plugins, pft_ablation, no_pft,
        thresholds, workers, limit, save_lanes, settings, overlays, diagnose, loc_iou, on_error, resume, dry_run, out,
        shard, executor, scheduler, no_timings, quiet, debug):
    """Evaluate the baseline, RONELD and any plug-in on a dataset's stored maps; write tables and curves.

    Clips run in parallel in time order, with RONELD's state carried within each clip. Outputs
    in OUT: accuracy.csv/.md/.tex, accuracy_curve.png/.svg, ablation.md/.tex (with
    --pft-ablation), runtime.csv/.md, per_frame.csv, official.csv, categories.csv/.png (CULane
    with category lists), overlays/ and overlays.png (with --overlays), lanes/ (with
    --save-lanes), errors.csv/.md/.png, frames.csv.gz, gallery.json, gallery/ and gallery.png
    (with --diagnose), report.html, summary.json, config.toml. OUT belongs to the run: files an
    earlier run wrote there and this one does not are removed; a folder holding other files is
    refused.
    """
    from . import api

    _no_collections_at_exit()

    def build() -> EvalConfig:
        config = _given_config(config_file, dataset, settings)
        overrides = {
            "dataset.data_root": None if data_root is None else str(data_root),
            "maps.root": None if maps_root is None else str(maps_root),
            "maps.format": maps_format,
            "dataset.list_file": None if list_file is None else str(list_file),
            "dataset.limit": limit,
            "methods": methods,  # comma-separated: the configuration splits and checks it
            "pft_ablation": pft_ablation,
            "paper.thresholds": thresholds,
            "workers": workers,
            "save_lanes": save_lanes,
            "on_error": on_error,
        }
        if no_pft and pft_ablation:
            raise ConfigError("--no-pft and --pft-ablation contradict each other: --no-pft runs RONELD only "
                              "without PFT, --pft-ablation runs it with and without")
        for setting in settings:
            key, value = parse_setting(setting)  # typed and checked as a TOML file's values
            overrides[key] = value
        if (data_root is None) != (maps_root is None):
            raise ConfigError("give both --data-root and --maps-root, or neither for the bundled fixture")
        if (overrides.get("maps.format") == "lanes" and config.maps.format != "lanes" and "model" not in overrides
                and (config_file is None or is_preset(config_file))):
            # A preset names the model whose maps it expects; these lanes are another detector's,
            # so its name must not label them (the lanes presets say "detector" too). A model the
            # user's own configuration names is theirs to claim.
            overrides["model"] = LANES_MODEL
        chosen = overrides.pop("methods")
        config = config.with_overrides(**overrides)
        added = []
        for plugin in plugins:
            name, equals, entry = plugin.partition("=")
            if not equals or not name.strip() or not entry.strip():
                raise ConfigError(f"--method needs NAME=MODULE:CALLABLE, got {plugin!r}")
            if name.strip() in added:
                raise ConfigError(f"--method {name.strip()} is given twice")
            config = config.with_plugin(name.strip(), entry.strip())
            added.append(name.strip())
        if chosen is not None:  # --methods may name the plug-ins; those it leaves out still run
            names = [part.strip() for part in chosen.split(",")] if isinstance(chosen, str) else list(chosen)
            config = config.with_overrides(methods=names + [name for name in added if name not in names])
        if no_pft:
            try:
                config = config.without_pft()  # 'roneld' becomes 'roneld-nopft'
            except ConfigError as error:
                raise ConfigError(f"--no-pft: {error}") from None
        from .resolve import configured

        return configured(config)[0]  # its benchmark's facts filled in, as the run fills them

    config = _guard(build, debug)
    _refuse_here_only(config, dry_run, diagnose, shard, executor, debug)
    if dry_run:
        _dry_run(config, quiet, debug, diagnose, loc_iou)
        return
    result = _guard(executed, debug, executor, scheduler, "run", api.run, config, out, progress=not quiet,
                    resume=resume, overlays=overlays, announce=_announcer(quiet), shard=shard, timings=not no_timings,
                    diagnose=diagnose, loc_iou=loc_iou)
    if result is None:  # a shard: its part is written
        shard_written(shard, out, quiet)
        return
    if not quiet:
        _print_summary(result, out)
    if result.diagnosed is not None and not quiet:
        from .metrics.lane_iou_f1 import highlighted
        from .report.diagnosis import console_lines

        for line in console_lines(result.diagnosed, highlighted(result.diagnosed.labels)[0]):
            click.echo(line)
    for note in result.notes:  # nothing left out, but worth knowing
        click.echo(f"note: {note}", err=True)
    if result.skipped:  # never silently, --quiet or not
        click.echo(f"skipped {len(result.skipped)} (listed in summary.json):", err=True)
        for line in result.skipped[:10]:
            click.echo(f"  {line}", err=True)
        if len(result.skipped) > 10:
            click.echo(f"  ... and {len(result.skipped) - 10} more", err=True)


def _refuse_here_only(config: EvalConfig, dry_run: bool, diagnose: bool, shard: str | None, executor: str,
                      debug: bool) -> None:
    """--dry-run and --diagnose work on the whole run in this process: refused with --shard or
    --executor dask (api.run refuses --diagnose with --shard itself, for the library's callers)."""
    if dry_run and (shard is not None or executor != "local"):
        _guard(_refuse, debug, "--dry-run checks the whole dataset's layout here: run it without --shard or --executor")
    if diagnose and executor != "local":
        _guard(_refuse, debug, "--diagnose writes a report, which the shards --executor dask runs do not: run with "
                               f"--save-lanes, then `roneld-eval score {config.dataset.name} --diagnose` on OUT/lanes "
                               "(it takes --executor dask)")


def _print_summary(result, out: Path) -> None:
    from .report import tables

    counts = result.counts
    protocol = tables.Protocol.of_run(result)
    click.echo(f"\n{result.dataset.name}: {counted(counts['clips'], 'clip')}, {counted(counts['frames'], 'frame')}, "
               f"{counts['labelled_frames']} scored, {counts['ego_lanes']} ego lanes; {result.wall_time_s:.1f} s")
    click.echo(f"paper's protocol: {protocol.paper()}; Acc. Inc.: {protocol.interval()}")
    click.echo(tables.comparison_table(result.accuracy, result.config.model, protocol.clips).to_markdown())
    benchmark = result.benchmark
    headline = tables.official_headline(result.official, benchmark, result.config.model)
    if headline is not None:  # what papers quote, beside the paper's table (every count in official.csv)
        click.echo(f"official {benchmark.display_name} scores (all counts in official.csv):")
        click.echo(headline.to_markdown())
    click.echo(f"results in {out}/")


class _BenchmarkCommands(click.Group):
    """`score BENCHMARK`: each installed benchmark brings its own command (Benchmark.score_command),
    imported only when it is the one asked for. `score --help` lists them from their entry
    points' metadata: a benchmark that hangs or exits at import cannot stop the list, and the
    list costs no benchmark's import."""

    def list_commands(self, ctx):
        return list(benchmark_names())

    def format_commands(self, ctx, formatter):
        rows = [(name, benchmark_origin(name)) for name in self.list_commands(ctx)]
        if rows:
            with formatter.section("Commands (`roneld-eval score NAME --help` says what each scores)"):
                formatter.write_dl(rows)

    def get_command(self, ctx, name):
        return self._command(name) if name in benchmark_names() else None

    @staticmethod
    def _command(name: str):
        """The benchmark's command; one that cannot be loaded or has none is one line, exit 2."""
        from .resolve import benchmark_named

        try:
            command = benchmark_named(name).score_command()
        except RoneldEvalError as error:  # a third party's is guarded (benchmarks.plugins)
            raise UsageProblem(str(error)) from None
        if command is None:
            raise UsageProblem(f"benchmark {name!r} has no `score` command: evaluate its maps with "
                               f"`roneld-eval run --dataset {name}`")
        return command


@main.group(cls=_BenchmarkCommands)
def score():
    """Score lane files in the official formats (no maps, any method's output)."""


def _refuse(message: str) -> NoReturn:
    raise ConfigError(message)


def shard_written(shard: str, out, quiet: bool) -> None:
    """What a command given --shard says: its part is written, merge the parts."""
    if not quiet:
        from .shards import parse_shard

        click.echo(f"shard {parse_shard(shard)}: part written to {out}; `roneld-eval merge` the parts of all shards")


@main.command()
@click.argument("parts", nargs=-1, required=True, type=click.Path(path_type=Path))
@click.option("--out", required=True, type=OUT_FOLDER,
              help="Folder for the merged results: what the command would have written unsharded.")
@debug_option
def merge(parts, out, debug):
    """Merge the parts of a sharded command (each written with --shard I/N to its own --out) into
    the files one unsharded command writes, byte for byte.

    Parts must be every shard 1..N of one command, written by this version with the same
    settings and ground truth, unchanged since (part.json's digests), their predictions too;
    anything else is refused in one line.
    """
    from .shards import merge as merge_parts

    command, result = _guard(merge_parts, debug, list(parts), out)
    click.echo(f"{counted(len(parts), 'part')} of `{command}` merged; results in {out}/")
    for line in (getattr(result, "skipped", None) or [])[:10]:  # a run's, as the run itself lists them
        click.echo(f"  skipped: {line}", err=True)


@main.command()
@click.option("--dataset", required=True, type=click.Choice(benchmark_names()), help="Layout to generate.")
@click.option("--out", required=True, type=OUT_FOLDER,
              help="Folder to write: OUT/data is the dataset root, OUT/maps the maps root.")
@click.option("--clips", default=3, show_default=True, type=click.IntRange(min=1), help="Number of clips.")
@click.option("--frames", type=click.IntRange(min=1), help="Frames per clip. Default: the benchmark's own clip length "
              "(where its clips end at their labelled frame: that frame and the ones before it).")
@click.option("--seed", default=0, show_default=True, type=click.IntRange(0, 2**63 - 1),
              help="Random seed; the same seed gives the same bytes.")
@click.option("--maps-format", type=MapFormatChoice(),
              help="How to store maps; lanes: a lane detector's output files instead of maps. Default: npy, or a "
                   "detector's lane files for the benchmarks scored from them.")
@debug_option
def synth(dataset, out, clips, frames, seed, maps_format, debug):
    """Generate a small realistic dataset with SCNN-like maps (4 channels, 288x800)."""
    from . import api
    from .progress import progress_bar
    from .resolve import benchmark_named

    benchmark = _guard(benchmark_named, debug, dataset)
    total = clips * (frames or benchmark.frames_per_clip)
    _guard(check_environment, debug)  # before the bar: a bound set wrong is one line, not under a bar
    with progress_bar(total, "frame", "generating", wanted=total >= 200) as bar:
        result = _guard(api.synthesize, debug, benchmark, out, clips, frames, seed, maps_format, bar.update)
    scored = result.score_command is not None  # a benchmark scored from lane files: labels and predictions
    click.echo(f"{'labels' if scored else 'data root'}: {result.data_root}")
    click.echo(f"{'predictions' if scored else 'maps root'}: {result.maps_root}")
    click.echo(f"{counted(result.n_clips, 'clip')}, {counted(result.n_frames, 'frame')}. "
               f"{'Score' if scored else 'Evaluate'} them with:")
    click.echo(f"  {result.command}")


@main.command()
@click.option("--run", "run_dir", required=True, type=click.Path(path_type=Path),
              help="A folder written by `roneld-eval run` (it holds config.toml and per_frame.csv), or by "
                   "`roneld-eval score ... --diagnose --out` (its gallery.json).")
@click.option("--frame", "frames", multiple=True, metavar="REL",
              help="A frame to draw, as its image path relative to the dataset root (repeatable).")
@click.option("--worst", type=click.IntRange(min=1),
              help="Draw the N frames where the baseline's and RONELD's IoUs differ most. Default: 6 without --frame. "
                   "A score's gallery: N frames a reason (default 3, at most the 6 it keeps).")
@click.option("--method", "methods", multiple=True, metavar="NAME",
              help="Methods to draw (repeatable). Default: those of the run.")
@click.option("--out", type=OUT_FOLDER,
              help="Folder for the pictures. Default: RUN/show (the run's own files are never touched).")
@click.option("--image-root", type=click.Path(path_type=Path),
              help="A score's gallery: where the frames' images are (default: the data root the score read, "
                   "where it holds them; a blank canvas of each frame's size without).")
@debug_option
def show(run_dir, frames, worst, methods, out, image_root, debug):
    """Draw frames of a run: camera image (or the maps), ground truth blue, baseline red, RONELD green.

    Each lane's IoU is written beside it; overlays.png gathers the pictures. They go to
    RUN/show (or --out), never over the run's own files.

    On a score written with --diagnose, its gallery: for each method the --worst frames (default
    3) with most errors in each category and with most of each error type, ground truth and every
    method's lanes, the counts in the caption (gallery/<k>.png and gallery.png), and report.html
    with the score's error table, its score sweep and the gallery. A run written with --diagnose
    drew its gallery itself (one frame a reason: OUT/gallery.png, in its report.html).
    """
    from . import api

    from .report.gallery import is_gallery

    if (frames or methods) and is_gallery(Path(run_dir)):
        _guard(_refuse, debug, "--frame and --method are for a run: a score's gallery draws the frames it chose")
    if image_root is not None and not is_gallery(Path(run_dir)):
        _guard(_refuse, debug, "--image-root is for a score's gallery: a run draws from its own data root")
    written = _guard(api.show, debug, run_dir, frames, worst, methods, out, image_root)
    for path in written:
        click.echo(str(path))


@main.command()
@click.argument("runs", nargs=-1, required=True, type=click.Path(path_type=Path))
@click.option("--out", type=OUT_FOLDER, default=Path("comparison"), show_default=True,
              help="Folder for the comparison (a new or empty folder, or one an earlier compare wrote).")
@click.option("--label", "labels", multiple=True, metavar="RUN=LABEL",
              help="Name a run's model in tables and legends (default: `model` of its config.toml); runs with "
                   "one label on one dataset are averaged as seeds (repeatable).")
@click.option("--thresholds", metavar="T,T,...",
              help="IoU thresholds of the table rows, each among the runs' thresholds. Default: 0.3,0.4,0.5 "
                   "(Table IV: 0.3,0.5).")
@click.option("--pair", "pairs", multiple=True, metavar="A,B",
              help="Also give B - A with a paired bootstrap interval over clips for two runs on the same frames, "
                   "each named by its folder (its path, or its own name where one run has it) or its label "
                   "(repeatable).")
@click.option("--allow-mixed", is_flag=True,
              help="Compare runs measured with different paper-protocol settings; every table says so in a note.")
@click.option("--quiet", is_flag=True, help="Print nothing but errors.")
@debug_option
def compare(runs, out, labels, thresholds, pairs, allow_mixed, quiet, debug):
    """Put finished runs side by side: the paper's Tables II-V and Fig. 5 across models, datasets, seeds.

    Reads folders written by `roneld-eval run` and writes comparison.csv, table_accuracy,
    table_ablation (when runs hold the PFT ablation), table_runtime and table_official (.md and
    .tex), curves.png/.svg/.pdf, with --pair pairs.csv and table_pairs, and summary.json. Runs
    of one dataset must share frames, ground truth and thresholds.

    Folders that `score` wrote for several prediction roots (sweep.csv) are checkpoint sweeps:
    sweeps.csv, sweeps.md (each sweep's best checkpoint) and sweeps.png, for sweeps of the same
    frames, lane width and thresholds.

    Folders that `score --diagnose` wrote (frames.csv.gz), holding two methods between them, are
    compared frame by frame: frames_compared.csv and .md list the frames where one method makes
    fewer errors (false positives plus false negatives) than the other, most first.
    """
    from .comparison import compare as compare_runs, parse_label_options
    from .comparison.sweeps import compare_sweeps, is_sweep

    _no_collections_at_exit()

    if _compared_frames(runs, out, bool(labels or thresholds or pairs), quiet, debug):
        return
    chosen = _guard(parse_label_options, debug, labels, runs)
    sweeps = [run for run in runs if is_sweep(run)]
    if sweeps:
        others = [run for run in runs if not is_sweep(run)]
        if others:
            _guard(_refuse, debug, f"{sweeps[0]} is a checkpoint sweep (sweep.csv) and {others[0]} is not: compare "
                                   "runs, or sweeps, not both at once")
        if thresholds or pairs:
            _guard(_refuse, debug, "--thresholds and --pair are for runs: a sweep compares its headline scores")
        compared = _guard(compare_sweeps, debug, runs, out, chosen, allow_mixed)
        if not quiet:
            click.echo((Path(out) / "sweeps.md").read_text(encoding="utf-8"))
            click.echo(f"{counted(len(compared.sweeps), 'sweep')} compared; results in {out}/")
        return
    result = _guard(compare_runs, debug, runs, out, chosen, thresholds, pairs, allow_mixed)
    if not quiet:
        click.echo((Path(out) / "table_accuracy.md").read_text(encoding="utf-8"))
        click.echo(f"{counted(len(result.runs), 'run')} compared; results in {out}/")


def _compared_frames(runs, out, run_options: bool, quiet: bool, debug: bool) -> bool:
    """compare of score folders written with --diagnose, frame by frame; False for other folders
    (checkpoint sweeps are compared as sweeps, diagnosed or not)."""
    from .comparison.frames import compare_frames, is_diagnosed
    from .comparison.sweeps import is_sweep

    if not any(is_diagnosed(run) for run in runs) or any(is_sweep(run) for run in runs):
        return False
    other = next((run for run in runs if not is_diagnosed(run)), None)
    if other is not None:
        _guard(_refuse, debug, f"{other} is not a score folder written with --diagnose (frames.csv.gz, and no "
                               "per_frame.csv of a run), and those are compared frame by frame with their own kind "
                               "alone: give only such folders, or only runs")
    if run_options:
        _guard(_refuse, debug, "score folders written with --diagnose are compared frame by frame: without --label, "
                               "--thresholds or --pair")
    found = _guard(compare_frames, debug, runs, out)
    if not quiet:
        click.echo(found.markdown)
        click.echo(f"every frame in {out}/frames_compared.csv")
    return True


class _ImageSize(click.ParamType):
    """WIDTHxHEIGHT in pixels, e.g. 1640x590."""

    name = "WxH"

    def convert(self, value, param, ctx):
        if isinstance(value, tuple):
            return value
        width, cross, height = str(value).lower().partition("x")
        if not cross or not width.strip().isdigit() or not height.strip().isdigit():
            self.fail(f"{value!r} is not WIDTHxHEIGHT (e.g. 1640x590)", param, ctx)
        size = int(width), int(height)
        if min(size) < 1:
            self.fail(f"{value!r}: width and height must be positive", param, ctx)
        return size


@main.command()
@click.option("--maps-root", required=True, type=click.Path(path_type=Path),
              help="The clip's maps: a folder of one clip's map files (its frames in name order), or with "
                   "--data-root the dataset's maps root, as `run` takes it.")
@click.option("--data-root", type=click.Path(path_type=Path),
              help="The dataset the clip belongs to (as `run` takes it): its frames in order, and the ground truth "
                   "that the active lanes are scored against.")
@click.option("--list", "list_file", type=click.Path(path_type=Path),
              help="With --data-root: the list of its frames (default: the dataset's list, as `run` reads it).")
@click.option("--clip", "clip_id", metavar="ID",
              help="With --data-root: the clip to replay (its folder, e.g. driver_37_30frame/05181432_0203.MP4). "
                   "Needed where the dataset holds several.")
@click.option("--config", "config_file", metavar="FILE|PRESET",
              help=f"Configuration file or preset ({', '.join(preset_names())}). Default: the dataset's "
                   "default preset (SCNN's, where there is one). A file that gives only some settings takes the "
                   "others from its dataset's preset.")
@click.option("--dataset", type=click.Choice(benchmark_names()),
              help="Benchmark whose default preset to use, and whose layout --data-root has.")
@click.option("--maps-format", type=MapFormatChoice(),
              help="How the maps are stored; lanes: a detector's lane files, drawn into maps. Default: the config's.")
@click.option("--image-size", type=_ImageSize(),
              help="The camera frame's size for a folder of maps, WIDTHxHEIGHT (default: the config's).")
@click.option("--no-pft", is_flag=True, help="Replay RONELD without preceding-frame tracking.")
@click.option("--set", "settings", multiple=True, metavar="SECTION.KEY=VALUE",
              help="Override one configuration value, as for `run` (repeatable).")
@click.option("--video", type=click.Path(path_type=Path), metavar="FILE.mp4",
              help="Write an MP4 of the clip: each frame with RONELD's active lanes (green) and, where labelled, "
                   "the ground truth (blue) and each lane's IoU.")
@click.option("--images", type=click.Path(path_type=Path),
              help="Camera frames for the video, <IMAGES>/<frame>.jpg (or .png). Default: the data root. "
                   "A frame without one is drawn on a blank canvas.")
@click.option("--fps", type=click.FloatRange(min=0.1, max=240), default=10.0, show_default=True,
              help="Frames per second of the video.")
@click.option("--quiet", is_flag=True, help="No progress bar; print only the figures.")
@debug_option
def replay(maps_root, data_root, list_file, clip_id, config_file, dataset, maps_format, image_size, no_pft, settings,
           video, images, fps, quiet, debug):
    """Run RONELD over one recorded clip frame by frame, as on a vehicle (roneld_eval.RoneldTracker).

    Prints the per-frame latency of the tracker's update (p50, p99, max; reading the maps apart),
    the paper's ego-lane accuracy where the clip has ground truth (as `run` scores it), and with
    --video writes an MP4 to watch the drive. Nothing else is written.
    """
    from .replay import replay_clip

    def build() -> EvalConfig:
        config = _given_config(config_file, dataset, settings)
        overrides = {"maps.root": str(maps_root), "maps.format": maps_format,
                     "dataset.data_root": None if data_root is None else str(data_root),
                     "dataset.list_file": None if list_file is None else str(list_file)}
        for setting in settings:
            key, value = parse_setting(setting)
            overrides[key] = value
        return config.with_overrides(**overrides)

    config = _guard(build, debug)
    result = _guard(replay_clip, debug, config, clip_id, video, images, image_size, not no_pft, fps,
                    progress=not quiet)
    _print_replay(result)


def _print_replay(result) -> None:
    latency = result.latency
    width, height = result.map_size
    click.echo(f"replayed {counted(result.frames, 'frame')} of {result.clip_id} with {result.method} "
               f"({width}x{height} maps)")
    click.echo(f"update per frame: p50 {latency.p50_ms:.3f} ms, p99 {latency.p99_ms:.3f} ms, "
               f"max {latency.max_ms:.3f} ms")
    if result.accuracy is None:
        click.echo("accuracy: no ground truth (give --data-root to score the clip)")
    else:
        rows = result.accuracy[result.accuracy["threshold"].isin(["0.30", "0.40", "0.50"])]
        shown = rows if len(rows) else result.accuracy.iloc[[0, -1]]
        click.echo(f"ego-lane accuracy (paper's protocol) over {counted(result.scored_frames, 'labelled frame')}: "
                   + ", ".join(f"{row.n_tp}/{row.n_gt} = {row.accuracy:.3f} at IoU > {row.threshold}"
                               for row in shown.itertuples()))
    if result.video is not None:
        click.echo(f"video: {result.video}")
    if result.without_image:
        click.echo(f"warning: --images has no picture of {counted(len(result.without_image), 'frame')} of "
                   f"{result.frames} (first: {result.without_image[0]}, looked for as itself and with "
                   ".jpg, .png, .jpeg): drawn on a blank canvas", err=True)
