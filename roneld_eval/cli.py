"""The `roneld-eval` command: options in, one library call, our errors out as one line (exit 2).

Nothing here computes anything; see api.py for the functions each command calls.
"""

from __future__ import annotations

import sys
import traceback
from pathlib import Path

import click

from . import __version__
from .config import DEFAULT_PRESETS, MAP_FORMATS, METHODS, EvalConfig, parse_setting, preset_names
from .errors import ConfigError, RoneldEvalError


class UsageProblem(click.ClickException):
    """A RoneldEvalError as click shows it: 'error: <path>:<line>: <problem>', exit status 2."""

    exit_code = 2

    def __init__(self, message: str, exit_code: int = 2):
        super().__init__(message)
        self.exit_code = exit_code

    def show(self, file=None):
        click.echo(f"error: {self.message}", err=True)


def _fail(error: BaseException, debug: bool):
    if debug:
        traceback.print_exception(error)
    raise UsageProblem(str(error), getattr(error, "exit_code", 2)) from None


def _guard(function, debug: bool, *args, **kwargs):
    """Call the library; bad input becomes one line and exit 2, Ctrl-C a short note and 130."""
    try:
        return function(*args, **kwargs)
    except RoneldEvalError as error:
        _fail(error, debug)
    except KeyboardInterrupt as error:
        from .signals import interruption_name

        reason, code = interruption_name(error)
        click.echo(f"{reason}: no result was written", err=True)
        sys.exit(code)
    except MemoryError:
        _fail(RoneldEvalError("out of memory (try fewer --workers)"), debug)
    except OSError as error:
        where = getattr(error, "filename", None)
        message = f"{where}: {error.strerror}" if where else str(error)
        _fail(RoneldEvalError(message), debug)


def _announcer(quiet: bool):
    """Where the library's one-line notes go: stderr, unless --quiet."""
    return None if quiet else (lambda message: click.echo(message, err=True))


debug_option = click.option("--debug", is_flag=True, help="Show the full traceback of an error.")


@click.group(context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 100})
@click.version_option(__version__, prog_name="roneld-eval")
def main():
    """Evaluate lane extractors on CULane and TuSimple from stored probability maps.

    Runs the SCNN/ENet-SAD baseline and RONELD on the same maps and reports the RONELD
    paper's active-lane accuracy, the official CULane F1 and TuSimple scores, and runtime.
    With no arguments, `roneld-eval run` evaluates the bundled fixture.
    """


@main.command()
@click.option("--config", "config_file", metavar="FILE|PRESET",
              help=f"Configuration TOML file or preset name ({', '.join(preset_names())}). "
                   "Default: the SCNN preset of the dataset.")
@click.option("--dataset", type=click.Choice(list(DEFAULT_PRESETS)),
              help="Benchmark layout of --data-root. Default: the config's, else culane.")
@click.option("--data-root", type=click.Path(path_type=Path),
              help="Dataset root (CULane: holds list/test.txt; TuSimple: holds test_label.json). "
                   "Without it and --maps-root, the bundled fixture is evaluated.")
@click.option("--maps-root", type=click.Path(path_type=Path),
              help="Folder of stored maps mirroring the dataset tree (<rel>/00000.npy for <rel>/00000.jpg).")
@click.option("--maps-format", type=click.Choice(MAP_FORMATS),
              help="How maps are stored: .npy, .npz, or SCNN's <frame>_<k>_avg.png + .exist.txt.")
@click.option("--list", "list_file", type=click.Path(path_type=Path),
              help="CULane list file (default <data-root>/list/test.txt) or TuSimple label file "
                   "(default <data-root>/test_label.json).")
@click.option("--methods", help=f"Comma-separated methods among {', '.join(METHODS)}. Default: baseline,roneld.")
@click.option("--pft-ablation", is_flag=True, default=None,
              help="Also run RONELD without preceding-frame tracking and write the ablation table.")
@click.option("--no-pft", is_flag=True, help="Run RONELD itself without preceding-frame tracking.")
@click.option("--thresholds", metavar="START:STOP:STEP",
              help="IoU thresholds of the accuracy sweep, inclusive. Default: 0.30:0.50:0.01.")
@click.option("--workers", type=click.IntRange(min=1), help="Worker processes (clips run in parallel). Default: all cores.")
@click.option("--limit", type=click.IntRange(min=1), help="Evaluate only the first N clips.")
@click.option("--save-lanes", is_flag=True, default=None,
              help="Also write every method's lanes in the official formats under OUT/lanes/.")
@click.option("--set", "settings", multiple=True, metavar="SECTION.KEY=VALUE",
              help="Override any configuration value, e.g. --set paper.thickness_rule=height (repeatable).")
@click.option("--overlays", type=click.IntRange(min=0), default=0,
              help="Also draw the N frames where the baseline and RONELD differ most (overlays/, overlays.png).")
@click.option("--on-error", type=click.Choice(["fail", "skip"]),
              help="On a bad frame, label or clip: stop with an error (default), or skip it and list it in "
                   "summary.json and on screen.")
@click.option("--resume", is_flag=True,
              help="Continue an interrupted run into the same --out: reuse its finished clips (same numbers).")
@click.option("--out", type=click.Path(path_type=Path), default=Path("results"), show_default=True,
              help="Folder for the results.")
@click.option("--quiet", is_flag=True, help="No progress bar or summary table.")
@debug_option
def run(config_file, dataset, data_root, maps_root, maps_format, list_file, methods, pft_ablation, no_pft,
        thresholds, workers, limit, save_lanes, settings, overlays, on_error, resume, out, quiet, debug):
    """Evaluate the baseline and RONELD on a dataset's stored maps and write tables and curves.

    Clips run in parallel in time order, with RONELD's state carried within each clip. Outputs
    in OUT: accuracy.csv/.md/.tex, accuracy_curve.png/.svg, ablation.md/.tex (with
    --pft-ablation), runtime.csv/.md, per_frame.csv, official.csv, categories.csv/.png (CULane
    with category lists), overlays/ and overlays.png (with --overlays), lanes/ (with
    --save-lanes), report.html, summary.json, config.toml. OUT belongs to the run: files an
    earlier run wrote there and this one does not are removed; a folder holding other files is
    refused.
    """
    from . import api

    def build() -> EvalConfig:
        if config_file is not None:
            config = EvalConfig.from_toml(config_file)
            if dataset is not None and dataset != config.dataset.name:
                raise ConfigError(f"--dataset {dataset} contradicts the config's dataset {config.dataset.name}")
        else:
            config = api.default_config(dataset or "culane")
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
        config = config.with_overrides(**overrides)
        if no_pft:
            try:
                config = config.without_pft()  # 'roneld' becomes 'roneld-nopft'
            except ConfigError as error:
                raise ConfigError(f"--no-pft: {error}") from None
        return config

    config = _guard(build, debug)
    result = _guard(api.run, debug, config, out, progress=not quiet, resume=resume, overlays=overlays,
                    announce=_announcer(quiet))
    if not quiet:
        _print_summary(result, out)
    if result.skipped:  # never silently, --quiet or not
        click.echo(f"skipped {len(result.skipped)} (listed in summary.json):", err=True)
        for line in result.skipped[:10]:
            click.echo(f"  {line}", err=True)
        if len(result.skipped) > 10:
            click.echo(f"  ... and {len(result.skipped) - 10} more", err=True)


def _print_summary(result, out: Path) -> None:
    from .report import tables

    counts = result.counts
    protocol = tables.Protocol.of_run(result)
    click.echo(f"\n{result.dataset.name}: {counts['clips']} clips, {counts['frames']} frames, "
               f"{counts['labelled_frames']} scored, {counts['ego_lanes']} ego lanes; {result.wall_time_s:.1f} s")
    click.echo(f"paper's protocol: {protocol.paper()}; Acc. Inc.: {protocol.interval()}")
    click.echo(tables.comparison_table(result.accuracy, result.config.model, protocol.clips).to_markdown())
    click.echo(f"results in {out}/")


@main.group()
def score():
    """Score lane files in the official formats (no maps, any method's output)."""


@score.command("culane")
@click.option("--data-root", required=True, type=click.Path(path_type=Path),
              help="CULane root with the ground-truth .lines.txt files and list/test.txt.")
@click.option("--pred-root", required=True, type=click.Path(path_type=Path),
              help="Predicted .lines.txt files mirrored under this folder; a missing file means no lanes.")
@click.option("--list", "list_file", type=click.Path(path_type=Path), help="List file (default <data-root>/list/test.txt).")
@click.option("--iou", default="0.5", show_default=True, metavar="T|START:STOP:STEP",
              help="IoU threshold, or a sweep scored in one pass (e.g. 0.30:0.50:0.01).")
@click.option("--width", default=30, show_default=True, type=click.IntRange(min=1), help="Lane width in pixels at 1640x590.")
@click.option("--workers", type=click.IntRange(min=1), help="Worker processes. Default: all cores.")
@click.option("--out", type=click.Path(path_type=Path), help="Folder for official.csv (and official_sweep.csv).")
@click.option("--quiet", is_flag=True, help="No progress bar or table.")
@debug_option
def score_culane_command(data_root, pred_root, list_file, iou, width, workers, out, quiet, debug):
    """Official CULane precision, recall and F1 per category, as SCNN's lane_evaluation computes them."""
    from . import api

    score = _guard(api.score_culane, debug, data_root, pred_root, list_file, iou, width, out, workers, not quiet,
                   _announcer(quiet))
    if not quiet:
        from .report.tables import Table

        rows = tuple(tuple(float(v) if isinstance(v, float) else str(v) for v in row)
                     for row in score.table.itertuples(index=False))
        click.echo(f"{score.n_frames} frames, IoU > {iou.split(':')[0]}, width {width}")
        click.echo(Table(tuple(score.table.columns), rows).to_markdown())


@score.command("tusimple")
@click.option("--labels", required=True, type=click.Path(path_type=Path), help="TuSimple label file (test_label.json).")
@click.option("--pred", required=True, type=click.Path(path_type=Path),
              help="Predictions, one JSON object per line: raw_file, lanes, h_samples, optional run_time (ms).")
@click.option("--out", type=click.Path(path_type=Path), help="Folder for official.csv.")
@click.option("--quiet", is_flag=True, help="Print nothing.")
@debug_option
def score_tusimple_command(labels, pred, out, quiet, debug):
    """Official TuSimple accuracy, FP and FN, as tusimple-benchmark's evaluate/lane.py computes them."""
    from . import api

    score = _guard(api.score_tusimple, debug, labels, pred, out)
    if not quiet:
        click.echo(f"{score.n_frames} frames: Accuracy {score.accuracy:.10g}  FP {score.fp:.10g}  FN {score.fn:.10g}")


@main.command()
@click.option("--dataset", required=True, type=click.Choice(list(DEFAULT_PRESETS)), help="Layout to generate.")
@click.option("--out", required=True, type=click.Path(path_type=Path),
              help="Folder to write: OUT/data is the dataset root, OUT/maps the maps root.")
@click.option("--clips", default=3, show_default=True, type=click.IntRange(min=1), help="Number of clips.")
@click.option("--frames", type=click.IntRange(min=1), help="Frames per clip. Default: 12 (CULane), 20 (TuSimple).")
@click.option("--seed", default=0, show_default=True, type=int, help="Random seed; the same seed gives the same bytes.")
@click.option("--maps-format", default="npy", show_default=True, type=click.Choice(MAP_FORMATS), help="How to store maps.")
@debug_option
def synth(dataset, out, clips, frames, seed, maps_format, debug):
    """Generate a small realistic dataset with SCNN-like maps (4 channels, 288x800)."""
    from tqdm import tqdm

    from . import api

    total = clips * (frames or (12 if dataset == "culane" else 20))
    with tqdm(total=total, unit="frame", desc="generating", disable=total < 200) as bar:
        result = _guard(api.synthesize, debug, dataset, out, clips, frames, seed, maps_format, bar.update)
    click.echo(f"data root: {result.data_root}")
    click.echo(f"maps root: {result.maps_root}")
    click.echo(f"{result.n_clips} clips, {result.n_frames} frames. Evaluate them with:")
    click.echo(f"  {result.command}")


@main.command()
@click.option("--run", "run_dir", required=True, type=click.Path(path_type=Path),
              help="A folder written by `roneld-eval run` (it holds config.toml and per_frame.csv).")
@click.option("--frame", "frames", multiple=True, metavar="REL",
              help="A frame to draw, as its image path relative to the dataset root (repeatable).")
@click.option("--worst", type=click.IntRange(min=1),
              help="Draw the N frames where the baseline's and RONELD's IoUs differ most. Default: 6 without --frame.")
@click.option("--method", "methods", multiple=True, type=click.Choice(METHODS),
              help="Methods to draw (repeatable). Default: those of the run.")
@click.option("--out", type=click.Path(path_type=Path),
              help="Folder for the pictures. Default: RUN/show (the run's own files are never touched).")
@debug_option
def show(run_dir, frames, worst, methods, out, debug):
    """Draw frames of a run: camera image (or the maps), ground truth blue, baseline red, RONELD green.

    Each lane's IoU is written beside it; overlays.png gathers the pictures. They go to
    RUN/show (or --out), never over the run's own files.
    """
    from . import api

    written = _guard(api.show, debug, run_dir, frames, worst, methods, out)
    for path in written:
        click.echo(str(path))
