"""Writing a run's results into the staging area of its output folder (see roneld_eval.output).

A run that fails or is interrupted before the end leaves no half-written result: files
appear only when the output folder commits them, all together.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import TYPE_CHECKING, TextIO

from ..benchmarks import Benchmark
from ..errors import InputError
from ..evaluation import FrameOutcome, RunResult
from ..methods import PAPER
from ..model import Frame, image_stem
from ..output import OutputFolder, Staging  # noqa: F401 (Staging: its old home)
from . import tables

if TYPE_CHECKING:  # overlays imports OpenCV, which a run without pictures does not need
    from .overlays import Overlays


class LaneWriter:
    """Streams each method's lanes into the staging folder, in the benchmark's official format
    (as its `lane_file` says: one file per frame, or one line per frame in a shared file)."""

    def __init__(self, staging: Staging, benchmark: Benchmark):
        self.staging = staging
        self.benchmark = benchmark
        self.handles: dict[str, TextIO] = {}
        self.frames: dict[str, None] = {}  # the frames written, in order (what `run --diagnose` scores)

    def __call__(self, outcome: FrameOutcome, frame: Frame) -> None:
        self.frames[frame.relpath] = None
        lane_file = self.benchmark.lane_file(outcome.method, frame, outcome.lanes)
        name = f"lanes/{lane_file.name}"
        if not lane_file.append:
            self.staging.write_text(name, lane_file.text)
            return
        try:
            handle = self.handles.get(name)
            if handle is None:
                handle = self.handles[name] = self.staging.file(name).open("w", encoding="utf-8")
            handle.write(lane_file.text)
        except OSError as error:  # a full disk: a write names no file of its own
            raise InputError.unwritable(self.staging.out_dir / name, error) from None

    def close(self) -> None:
        failed = None
        for name, handle in self.handles.items():
            try:
                handle.close()  # every one, even after one fails (its buffer could not be written)
            except OSError as error:
                failed = failed or InputError.unwritable(self.staging.out_dir / name, error)
        if failed is not None:
            raise failed


def _json_safe(value):
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_safe(v) for v in value]
    return value


def summary(result: RunResult) -> dict:
    """Everything needed to rerun and to trust the run: config, versions, counts, timing (and,
    where a benchmark's videos come in several sizes, each clip's: compare refuses runs that
    scored the same clips at other sizes)."""
    sizes = {clip.clip_id: list(clip.frames[0].image_size) for clip in result.dataset.clips
             if clip.frames and clip.frames[0].image_size is not None}
    extra: dict[str, object] = {"clip_sizes": sizes} if sizes else {}
    if result.notes:
        extra["notes"] = result.notes
    if result.diagnosed is not None:  # run --diagnose: not in config.toml, so recorded here
        extra["diagnosis"] = {"loc_iou": result.diagnosed.loc_iou, "thresholds": list(result.diagnosed.labels),
                              "metric": result.diagnosed.title}
    return _json_safe({
        "tool": "roneld-eval",
        "dataset": result.dataset.name,
        "data_root": f"bundled fixture ({result.fixture})" if result.fixture else str(result.dataset.root),
        "source_file": None if result.fixture or not result.dataset.source_file else str(result.dataset.source_file),
        "config": result.config.to_dict(),
        "geometry": None if result.geometry is None else result.geometry.to_dict(),
        "versions": result.versions if result.timed else _untimed_versions(result.versions),
        "counts": result.counts,
        "skipped": result.skipped,
        "wall_time_s": round(result.wall_time_s, 3) if result.timed else None,
        "rerun": "roneld-eval run --config config.toml",
        **extra,
    })


def _untimed_versions(versions: dict) -> dict:
    """An untimed run's versions: its platform as the system and processor kind alone. The
    kernel build and C library it also named vary from machine to machine and explain timings,
    which such a run leaves out: a refreshed results/ then equals the committed one, byte for byte."""
    import platform

    return {**versions, "platform": f"{platform.system()}-{platform.machine()}"}


def config_record(result: RunResult) -> str:
    """config.toml: the effective configuration, headed by what it really meant for these maps."""
    header = "# roneld-eval run --config config.toml reruns this evaluation.\n"
    if result.geometry is not None:
        header += f"# Effective geometry of this run: {result.geometry.describe()}.\n"
    return header + "\n" + result.config.to_toml()


def write_pictures(staging: Staging, overlays: Overlays) -> None:
    """overlays/<frame>.png for each picture, each with the legend, and overlays.png, the
    contact sheet, with the legend once above them all."""
    import cv2

    from .overlays import OUTPUT_WIDTH, contact_sheet, draw_legend, legend_strip

    for relpath, image in overlays.pictures:
        name = image_stem(relpath).replace("/", "__") + ".png"
        if not cv2.imwrite(str(staging.file(f"overlays/{name}")), draw_legend(image.copy(), overlays.legend)):
            raise InputError(staging.out_dir / "overlays" / name, "cannot write")
    if not overlays.pictures:
        return
    columns = 2  # the sheet is shown at about half size: its legend is drawn at twice a picture's
    sheet = contact_sheet([image for _, image in overlays.pictures],
                          legend_strip(overlays.legend, columns * OUTPUT_WIDTH, scale=columns), columns)
    if not cv2.imwrite(str(staging.file("overlays.png")), sheet):
        raise InputError(staging.out_dir / "overlays.png", "cannot write")


UNTIMED = ("Not measured: this run was written with --no-timings, which leaves out what the clock measures "
           "(runtime per frame and the wall time), so that running it again writes the same bytes.")


def _stage_runtime(result: RunResult, staging: Staging, source: str, protocol, model: str) -> None:
    """runtime.csv and runtime.md: Table V, or, for an untimed run, the frames alone and why."""
    if not result.timed:
        frames = result.runtime[["method", "frames"]].assign(mean_ms=math.nan, median_ms=math.nan, p95_ms=math.nan)
        staging.write_csv("runtime.csv", frames)
        staging.write_text("runtime.md", f"# Runtime per frame on {source}\n\n{UNTIMED}\n")
        return
    staging.write_csv("runtime.csv", result.runtime)
    skewed = [str(row["method"]) for row in result.runtime.to_dict("records") if row["mean_ms"] > row["p95_ms"]]
    skew_note = (f"\n\nA mean above its 95th percentile ({', '.join(skewed)}): fewer than one frame in 20 took far "
                 "longer than the rest (a slow disk read, the machine busy with other work), and the median is the "
                 "typical frame." if skewed else "")
    staging.write_text("runtime.md", f"# Runtime per frame on {source}\n\n"
                       f"Milliseconds per frame of extraction alone (after numba warm-up, one-time imports left "
                       f"out), map loading apart, on {protocol.map_size()}.\n\n"
                       + tables.runtime_table(result.runtime, model).to_markdown()
                       + skew_note)


def write_report(result: RunResult, out_dir: str | Path) -> list[Path]:
    """Write every output file of a run into `out_dir` (see README for what each holds)."""
    with OutputFolder(out_dir, "run") as folder:
        stage_report(result, Staging(folder))
        return folder.commit()


def load_drawing() -> None:
    """Import what drawing the report's figures takes (matplotlib: ~0.35 s), ahead of
    stage_report, e.g. while a run's workers warm up and this process would only wait."""
    from . import html, plots  # noqa: F401


def stage_report(result: RunResult, staging: Staging) -> None:
    """Write the report's files into a staging folder (they appear on its commit).

    Every label names the configuration behind its numbers: method names come from the method
    alone, and each table and figure states the map size, thicknesses and IoU threshold the run
    really used (`result.geometry`; the configuration's when the run recorded none).
    """
    config = result.config
    model = config.model
    protocol = tables.Protocol.of_run(result)
    name = result.benchmark.display_name
    maps = f"{model}'s lanes drawn into maps" if config.maps.format == "lanes" else f"{model} probability maps"
    source = f"the bundled {name} fixture (synthetic {model}-like maps)" if result.fixture else f"{name}, {maps}"
    paper_note = f"The RONELD paper's protocol: {protocol.paper()}; a true positive needs IoU > the row's threshold."
    staging.write_csv("accuracy.csv", result.accuracy)
    if result.gains is not None:
        staging.write_csv("gains.csv", result.gains)
    comparison = tables.comparison_table(result.accuracy, model, protocol.clips)
    increase_note = ("Acc. Inc.: RONELD's increase over the method two columns to its left, "
                     f"its {protocol.interval()}, in bold relative to that method.")
    staging.write_text("accuracy.md", f"# Accuracy on {source}\n\n{paper_note} {increase_note}\n\n"
                       + comparison.to_markdown())
    staging.write_text("accuracy.tex", comparison.to_latex(
        f"Ego-lane accuracy on {source}. {paper_note} Acc. Inc. is RONELD's increase over the method two "
        f"columns to its left, in bold relative to that method; beneath it, its {protocol.interval()}.",
        f"tab:accuracy-{result.dataset.name}", wide=True))
    ablation = tables.ablation_table(result.accuracy, name, model)
    if ablation is not None:
        pft_note = (f"w/ PFT: the method '{PAPER.ours}' (RONELD with preceding-frame tracking); w/o PFT: the method "
                    f"'{PAPER.without_tracking}'. {paper_note}")
        staging.write_text("ablation.md", f"# {tables.display_name(PAPER.ours, model)} with and without PFT on "
                           f"{source}\n\n{pft_note}\n\n" + ablation.to_markdown())
        staging.write_text("ablation.tex", ablation.to_latex(
            f"Accuracy of {tables.display_name(PAPER.ours, model)} with and without preceding frame tracking (PFT) "
            f"on {source}. {paper_note}", f"tab:pft-{result.dataset.name}"))
    _stage_runtime(result, staging, source, protocol, model)
    staging.write_csv("per_frame.csv", result.per_frame)
    staging.write_csv("official.csv", result.official)
    staging.write_text("config.toml", config_record(result))
    staging.write_text("summary.json", json.dumps(summary(result), indent=2) + "\n")
    from .figure_files import save_figure
    from .plots import accuracy_figure, category_figure  # matplotlib: imported only to draw

    figure = accuracy_figure(result.accuracy, model, source, protocol)
    save_figure(figure, [staging.file("accuracy_curve.png"), staging.file("accuracy_curve.svg")])
    if result.dataset.categories:
        from ..metrics.sweep import category_accuracy

        threshold = config.official.iou_threshold
        by_category = category_accuracy(result.per_frame, result.dataset.categories, threshold, config.methods)
        staging.write_csv("categories.csv", by_category)
        panel = result.benchmark.category_panel(result.official, protocol)
        save_figure(category_figure(by_category, panel, model, f"{threshold:g}", protocol),
                    [staging.file("categories.png")])
    from .html import build_html

    staging.write_text("report.html", build_html(staging.path, result.benchmark))
