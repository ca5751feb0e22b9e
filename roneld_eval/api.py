"""The library's front door: one function per CLI command, with the same names and options.

`run` evaluates and writes a report, `score_culane` / `score_tusimple` score lane files in
the official formats, `synthesize` writes a generated dataset. The bundled fixture lives in
`roneld_eval/_fixture` and is what `run` uses when no dataset is given.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Callable, Sequence

import numpy as np
import pandas as pd

from . import __version__
from .config import DEFAULT_PRESETS, IMAGE_SIZES, EvalConfig, parse_thresholds
from .datasets import read_culane
from .datasets.culane import labels_path
from .errors import ConfigError, InputError, RunInterrupted
from .cache import ResultCache
from .evaluation import RunResult, evaluate
from .output import JOURNAL, OutputFolder, read_manifest
from .signals import interruption_name, terminate_as_interrupt
from .workers import default_workers, process_pool, stopping
from .lanes_io import read_culane_lines
from .metrics.culane_official import (
    CulaneFrameResult,
    category_table,
    evaluate_culane_frame,
)
from .metrics.tusimple_official import TusimpleScore, score_tusimple_files
from .model import Frame
from .report.tables import Protocol
from .report.write import LaneWriter, Staging, stage_report
from .synth import SynthResult, synthesize

FIXTURE_MAPS_FORMAT = "npz"


def fixture_roots(dataset: str) -> tuple[Path, Path]:
    """(data root, maps root) of the bundled fixture of a dataset."""
    base = Path(str(resources.files("roneld_eval._fixture"))) / dataset
    data, maps = base / "data", base / "maps"
    if not data.is_dir() or not maps.is_dir():
        raise InputError(base, "the bundled fixture is missing from this installation")
    return data, maps


def default_config(dataset: str = "culane") -> EvalConfig:
    """The preset for a dataset's default model (SCNN)."""
    if dataset not in DEFAULT_PRESETS:
        raise ConfigError(f"unknown dataset {dataset!r}")
    return EvalConfig.preset(DEFAULT_PRESETS[dataset])


def with_fixture(config: EvalConfig) -> EvalConfig:
    """The configuration pointed at the bundled fixture when it names no data."""
    if config.dataset.data_root is not None or config.maps.root is not None:
        return config
    data, maps = fixture_roots(config.dataset.name)
    return config.with_overrides(**{"dataset.data_root": str(data), "maps.root": str(maps),
                                    "maps.format": FIXTURE_MAPS_FORMAT})


def with_absolute_paths(config: EvalConfig) -> EvalConfig:
    """The configuration with every path made absolute, so its config.toml works from anywhere."""
    def absolute(value: str | None) -> str | None:
        return None if value is None else os.path.abspath(os.path.expanduser(value))

    return config.with_overrides(**{
        "dataset.data_root": absolute(config.dataset.data_root),
        "maps.root": absolute(config.maps.root),
        "dataset.list_file": absolute(config.dataset.list_file),
    })


def run(config: EvalConfig | None = None, out: str | Path = "results", progress: bool = True,
        resume: bool = False, overlays: int = 0, announce: Callable[[str], None] | None = None) -> RunResult:
    """Evaluate every configured method and write the report to `out` (see the README).

    Finished clips are kept in `out` while the run goes on; after an interruption,
    `resume=True` evaluates only the clips not yet finished and gives the same numbers.
    `overlays=N` also draws the N frames where the baseline and RONELD differ most.
    `announce` receives one-line notes (the geometry used, what resume reused).
    The folder `out` is the run's own: see roneld_eval.output.
    """
    requested = with_absolute_paths(config or default_config())
    config = with_fixture(requested)
    say = announce or (lambda message: None)
    with terminate_as_interrupt(), OutputFolder(out, "run", nested={SHOW_FOLDER: "show"}) as folder:
        staging = Staging(folder)
        cache = ResultCache(folder.path, config, __version__, resume, note=say)
        try:
            writer = LaneWriter(staging, config.dataset.name) if config.save_lanes else None
            dataset = None
            if writer is not None and config.dataset.name == "tusimple":
                from .datasets import read_dataset

                dataset = read_dataset(config.dataset.name, config.dataset.data_root, config.dataset.list_file,
                                       config.dataset.limit)
                writer.h_samples = {f.relpath: f.h_samples for c in dataset.clips for f in c.frames if f.labelled}
            try:
                result = evaluate(config, progress=progress, lane_sink=writer, dataset=dataset, cache=cache,
                                  announce=say)
            except RunInterrupted as error:  # a worker died: say what is kept for --resume
                raise RunInterrupted(_unfinished(str(error), cache), exit_code=error.exit_code) from None
            if resume:
                say(f"resume: {cache.summary()}")
            if writer is not None:
                writer.close()
            if config is not requested:
                # Record the bundled fixture by name, not by this machine's paths, so the written
                # config.toml reruns anywhere.
                result.config = requested
                result.fixture = config.dataset.name
            if overlays:
                from .report.overlays import worst_frames
                from .report.write import write_pictures

                chosen = worst_frames(result.per_frame, overlays)
                protocol = Protocol.of_run(result).paper_short()
                write_pictures(staging, frame_pictures(config, result.dataset, chosen, list(config.methods), protocol))
            stage_report(result, staging)
            folder.commit(then=cache.discard)  # a signal meanwhile waits, then says the results are complete
        except RunInterrupted:
            raise  # finished clips stay for --resume
        except KeyboardInterrupt as error:  # Ctrl-C, SIGTERM or SIGHUP, evaluating or writing the report
            reason, code = interruption_name(error)
            raise RunInterrupted(_unfinished(reason, cache), exit_code=code) from None
        except BaseException:
            cache.discard()  # bad input or a bug: nothing to resume from
            raise
    return result


def _unfinished(reason: str, cache: ResultCache) -> str:
    done = cache.count()
    if not done:
        cache.discard()  # an empty cache folder would only be clutter
    kept = (f"{done} finished clip{'s' if done != 1 else ''} kept in {cache.folder}; run the same command "
            f"with --resume to continue") if done else "nothing to resume from"
    return f"{reason}: no result was written; {kept}"


# ---- scoring lane files ----------------------------------------------------------------------


@dataclass
class CulaneScore:
    """Official CULane scores of a prediction tree: per category at each threshold."""

    table: pd.DataFrame  # category, tp, fp, fn, precision, recall, f1 at the first threshold
    sweep: pd.DataFrame  # iou_threshold, category, tp, fp, fn, precision, recall, f1
    n_frames: int


def _score_frames(args) -> list[tuple[str, CulaneFrameResult]]:
    frames, pred_root, width, height, lane_width = args
    out = []
    for frame in frames:
        predictions = read_culane_lines(labels_path(Path(pred_root), frame.relpath))
        out.append((frame.relpath, evaluate_culane_frame(frame.lanes, predictions, width, height, lane_width)))
    return out


def score_culane(data_root: str | Path, pred_root: str | Path, list_file: str | Path | None = None,
                 iou: str | float = 0.5, width: int = 30, out: str | Path | None = None,
                 workers: int | None = None, progress: bool = False,
                 announce: Callable[[str], None] | None = None) -> CulaneScore:
    """Score `.lines.txt` predictions (mirrored under pred_root) with the official CULane protocol.

    `iou` is one threshold or a sweep ('0.30:0.50:0.01'); every threshold costs one pass.
    A missing prediction file means no lanes.
    """
    pred_root = Path(pred_root)
    if not pred_root.is_dir():
        raise InputError(pred_root, "prediction root not found")
    if width < 1:
        raise ConfigError(f"lane width must be positive, got {width}")
    thresholds = parse_thresholds(str(iou))
    dataset = read_culane(data_root, list_file, require_labels=True)
    image_width, image_height = IMAGE_SIZES["culane"]
    frames: list[Frame] = [frame for clip in dataset.clips for frame in clip.frames]
    chunks = [frames[i:i + 200] for i in range(0, len(frames), 200)]
    tasks = [(chunk, pred_root, image_width, image_height, width) for chunk in chunks]
    workers = min(workers or default_workers(), max(len(chunks), 1))
    from . import kernels

    kernels.prepare(announce=announce, needed=("official",))  # once here, not in every worker
    from tqdm import tqdm

    results: dict[str, CulaneFrameResult] = {}
    with tqdm(total=len(frames), unit="frame", desc="scoring", disable=not progress) as bar:
        if workers > 1:
            died = "a worker process died (killed, or out of memory) while scoring: no result was written"
            with stopping(process_pool(workers), lambda: died) as pool:
                for piece in pool.map(_score_frames, tasks):
                    results.update(piece)
                    bar.update(len(piece))
        else:
            for piece in map(_score_frames, tasks):
                results.update(piece)
                bar.update(len(piece))
    sweep = []
    for label, value in zip(thresholds.labels, thresholds.values):
        table = category_table(results, dataset.categories, value)
        table.insert(0, "iou_threshold", label)
        sweep.append(table)
    sweep_table = pd.concat(sweep, ignore_index=True)
    first = sweep_table[sweep_table["iou_threshold"] == thresholds.labels[0]].drop(columns="iou_threshold")
    score = CulaneScore(first.reset_index(drop=True), sweep_table, len(frames))
    if out is not None:
        with terminate_as_interrupt(), OutputFolder(out, "score culane") as folder:
            staging = Staging(folder)
            staging.write_text("official.csv", score.table.to_csv(index=False, float_format="%.6f", lineterminator="\n"))
            if len(thresholds) > 1:
                staging.write_text("official_sweep.csv", sweep_table.to_csv(index=False, float_format="%.6f",
                                                                            lineterminator="\n"))
            folder.commit()
    return score


def score_tusimple(labels: str | Path, pred: str | Path, out: str | Path | None = None) -> TusimpleScore:
    """Score TuSimple JSON-lines predictions against a label file, as evaluate/lane.py does."""
    score = score_tusimple_files(labels, pred)
    if out is not None:
        with terminate_as_interrupt(), OutputFolder(out, "score tusimple") as folder:
            table = pd.DataFrame([dict(accuracy=score.accuracy, fp=score.fp, fn=score.fn)])
            Staging(folder).write_text("official.csv", table.to_csv(index=False, float_format="%.10g",
                                                                    lineterminator="\n"))
            folder.commit()
    return score


__all__ = ["run", "show", "score_culane", "score_tusimple", "synthesize", "fixture_roots", "default_config",
           "CulaneScore", "SynthResult"]


# ---- pictures --------------------------------------------------------------------------------


def frame_pictures(config: EvalConfig, dataset, frames: Sequence[str], methods: Sequence[str], protocol: str = ""):
    """(relpath, picture) for each frame: its clip is evaluated again up to it (RONELD's state).

    `protocol` says in a few words how the IoUs written beside the lanes were measured."""
    from dataclasses import replace

    import cv2

    from .datasets import load_labels
    from .evaluation import RunContext, evaluate_clip
    from .maps import load_maps
    from .metrics.paper import ego_lanes
    from .report.overlays import FramePicture, draw_frame, heat_map
    from .report.tables import display_name

    wanted = list(dict.fromkeys(frames))
    clip_of = {f.relpath: clip for clip in dataset.clips for f in clip.frames}
    missing = [f for f in wanted if f not in clip_of]
    if missing:
        raise InputError(dataset.source_file, f"frame {missing[0]} is not in this run's dataset")
    labelled = {clip.clip_id: load_labels(dataset, clip) for clip in {clip_of[f].clip_id: clip_of[f] for f in wanted}.values()}
    clip_of = {f: labelled[clip_of[f].clip_id] for f in wanted}
    methods = [m for m in methods if m in config.methods] or list(config.methods)
    run_config = config.with_overrides(save_lanes=True, methods=tuple(methods), pft_ablation=False)
    context = RunContext(run_config, dataset.name, dataset.image_width, dataset.image_height, Path(config.maps.root))
    outcomes = {}
    for clip in dict.fromkeys(clip_of[f] for f in wanted).keys():
        last = max(i for i, f in enumerate(clip.frames) if f.relpath in wanted)
        part = replace(clip, frames=clip.frames[:last + 1])
        for outcome in evaluate_clip(part, context).outcomes:
            outcomes[(outcome.relpath, outcome.method)] = outcome
    pictures = []
    for relpath in wanted:
        frame = next(f for f in clip_of[relpath].frames if f.relpath == relpath)
        if not frame.labelled:
            raise InputError(dataset.source_file, f"frame {relpath} has no labels to compare with")
        image_path = Path(config.dataset.data_root) / relpath
        background = cv2.imread(str(image_path)) if image_path.is_file() else None
        if background is None:
            geometry = config.geometry
            maps = load_maps(Path(config.maps.root), relpath, config.maps).probabilities
            background = heat_map(np.asarray(maps), dataset.image_width, dataset.image_height,
                                  geometry.crop_top_px, geometry.crop_bottom_px)
        elif background.shape[:2] != (dataset.image_height, dataset.image_width):
            background = cv2.resize(background, (dataset.image_width, dataset.image_height))
        left, right = ego_lanes(frame.lanes, dataset.image_width, dataset.image_height, config.roneld.center_ratio)
        chosen = {id(left), id(right)}
        picture = FramePicture(
            relpath=relpath,
            ground_truth=(left, right),
            other_ground_truth=tuple(l for l in frame.lanes if id(l) not in chosen and len(l) >= 2),
            lanes={m: outcomes[(relpath, m)].active for m in methods if (relpath, m) in outcomes},
            ious={m: outcomes[(relpath, m)].ious for m in methods if (relpath, m) in outcomes},
        )
        scores = "  ".join(
            f"{display_name(m, config.model)}: " + " ".join(f"{side[0].upper()} {iou:.2f}" for side, iou in picture.ious[m].items())
            for m in picture.ious)
        pictures.append((relpath, draw_frame(picture, background, config.model, f"{relpath}   {scores}",
                                                      protocol=protocol)))
    return pictures


def show(run_dir: str | Path, frames: Sequence[str] = (), worst: int | None = None, methods: Sequence[str] = (),
         out: str | Path | None = None) -> list[Path]:
    """Draw frames of a finished run (given ones, or the `worst` N where methods differ most).

    Pictures go to `out` (default: `<run>/show/`), never over the run's own files:
    overlays/<frame>.png and the contact sheet overlays.png.
    """
    run_dir = Path(run_dir)
    check_finished_run(run_dir)
    requested = EvalConfig.from_toml(run_dir / "config.toml")
    config = with_fixture(requested)
    try:
        per_frame = pd.read_csv(run_dir / "per_frame.csv")
    except (OSError, ValueError, pd.errors.ParserError) as error:
        raise InputError(run_dir / "per_frame.csv", f"cannot read: {error}") from None
    if list(per_frame.columns) != ["frame", "side", "method", "iou"]:
        raise InputError(run_dir / "per_frame.csv", "not a per-frame table of this tool (columns frame, side, method, iou)")
    chosen = list(frames)
    if worst or not chosen:
        from .report.overlays import worst_frames

        chosen += worst_frames(per_frame, worst or 6)
    from .datasets import read_dataset

    dataset = read_dataset(config.dataset.name, config.dataset.data_root, config.dataset.list_file, config.dataset.limit)
    try:
        recorded = Protocol.from_summary(json.loads((run_dir / "summary.json").read_text(encoding="utf-8")))
    except (OSError, ValueError, AttributeError, TypeError):
        recorded = None
    pictures = frame_pictures(config, dataset, chosen, methods, recorded.paper_short() if recorded else "")
    target = Path(out) if out is not None else run_dir / SHOW_FOLDER
    if target.resolve() == run_dir.resolve():
        raise InputError(target, "pictures go to their own folder, not over the run's files: choose another --out")
    from .report.write import write_pictures

    with terminate_as_interrupt(), OutputFolder(target, "show") as folder:
        write_pictures(Staging(folder), pictures)
        return folder.commit()


SHOW_FOLDER = "show"


def check_finished_run(run_dir: Path) -> None:
    """Stop unless `run_dir` holds the complete results of `roneld-eval run`."""
    if not run_dir.is_dir():
        raise InputError(run_dir, "not found: give a folder written by `roneld-eval run`")
    manifest = read_manifest(run_dir)
    if manifest is None:
        raise InputError(run_dir, "not a folder written by `roneld-eval run` (it has no run manifest)")
    if manifest["command"] != "run":
        raise InputError(run_dir, f"not a folder written by `roneld-eval run` (`roneld-eval {manifest['command']}` "
                                  f"wrote it)")
    if (run_dir / JOURNAL).exists():
        raise InputError(run_dir, "its results are incomplete (a run was killed while putting them in place); "
                                  "run it again into this folder")
    for name in ("config.toml", "per_frame.csv"):
        if name not in manifest["entries"] or not (run_dir / name).is_file():
            raise InputError(run_dir / name, "missing from this run folder")
