"""Writing a run's results: every file to a staging folder first, then renamed into place.

A run that fails or is interrupted before the end leaves no half-written result: files
appear only once they are complete (os.replace is atomic on one filesystem).
"""

from __future__ import annotations

import json
import math
import os
import shutil
import tempfile
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..evaluation import FrameOutcome, RunResult
from ..lanes_io import format_culane_lines, format_tusimple_record, sample_lane_at_rows
from . import tables


class Staging:
    """A private folder inside the output folder; `commit()` moves its files into place.

    As a context manager it commits when the block ends normally and discards everything when
    it raises, so no reader ever sees a half-written set of results.
    """

    def __init__(self, out_dir: Path):
        self.out_dir = Path(out_dir)
        try:
            self.out_dir.mkdir(parents=True, exist_ok=True)
            self.path = Path(tempfile.mkdtemp(prefix=".staging-", dir=self.out_dir))
        except OSError as error:
            raise InputError(self.out_dir, f"cannot write results here: {error.strerror}") from None

    def __enter__(self) -> "Staging":
        return self

    def __exit__(self, kind, error, trace) -> bool:
        if kind is None:
            self.written = self.commit()
        else:
            self.discard()
        return False

    def file(self, name: str) -> Path:
        path = self.path / name
        path.parent.mkdir(parents=True, exist_ok=True)
        return path

    def write_text(self, name: str, text: str) -> None:
        try:
            self.file(name).write_text(text)
        except OSError as error:
            raise InputError(self.out_dir / name, f"cannot write: {error.strerror}") from None

    def commit(self) -> list[Path]:
        """Move every staged entry into the output folder (replacing older results)."""
        written = []
        for entry in sorted(self.path.iterdir()):
            target = self.out_dir / entry.name
            if entry.is_dir():
                if target.exists():
                    old = self.out_dir / f".old-{entry.name}-{os.getpid()}"
                    target.rename(old)
                    entry.rename(target)
                    shutil.rmtree(old, ignore_errors=True)
                else:
                    entry.rename(target)
            else:
                os.replace(entry, target)
            written.append(target)
        self.discard()
        return written

    def discard(self) -> None:
        shutil.rmtree(self.path, ignore_errors=True)


class LaneWriter:
    """Streams each method's lanes into the staging folder in the official formats."""

    def __init__(self, staging: Staging, dataset: str):
        self.staging = staging
        self.dataset = dataset
        self.handles: dict[str, object] = {}
        self.h_samples: dict[str, tuple] = {}

    def __call__(self, outcome: FrameOutcome) -> None:
        if self.dataset == "culane":
            stem = outcome.relpath.rsplit(".", 1)[0]
            self.staging.write_text(f"lanes/{outcome.method}/{stem}.lines.txt", format_culane_lines(outcome.lanes))
            return
        handle = self.handles.get(outcome.method)
        if handle is None:
            handle = self.staging.file(f"lanes/{outcome.method}/predictions.json").open("w")
            self.handles[outcome.method] = handle
        rows = self.h_samples.get(outcome.relpath, ())
        lanes_xs = [sample_lane_at_rows(lane, rows) for lane in outcome.lanes]
        handle.write(format_tusimple_record(outcome.relpath, lanes_xs, rows, 0) + "\n")

    def close(self) -> None:
        for handle in self.handles.values():
            handle.close()


def _json_safe(value):
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_safe(v) for v in value]
    return value


def summary(result: RunResult) -> dict:
    """Everything needed to rerun and to trust the run: config, versions, counts, timing."""
    return _json_safe({
        "tool": "roneld-eval",
        "dataset": result.dataset.name,
        "data_root": f"bundled fixture ({result.fixture})" if result.fixture else str(result.dataset.root),
        "source_file": None if result.fixture or not result.dataset.source_file else str(result.dataset.source_file),
        "config": result.config.to_dict(),
        "versions": result.versions,
        "counts": result.counts,
        "skipped": result.skipped,
        "wall_time_s": round(result.wall_time_s, 3),
        "rerun": "roneld-eval run --config config.toml",
    })


def write_pictures(staging: Staging, pictures: list[tuple[str, np.ndarray]]) -> None:
    """overlays/<frame>.png for each picture and overlays.png, the contact sheet."""
    import cv2

    from .overlays import contact_sheet

    for relpath, image in pictures:
        name = relpath.rsplit(".", 1)[0].replace("/", "__") + ".png"
        if not cv2.imwrite(str(staging.file(f"overlays/{name}")), image):
            raise InputError(staging.out_dir / "overlays" / name, "cannot write")
    if pictures and not cv2.imwrite(str(staging.file("overlays.png")), contact_sheet([image for _, image in pictures])):
        raise InputError(staging.out_dir / "overlays.png", "cannot write")


def write_report(result: RunResult, out_dir: str | Path) -> list[Path]:
    """Write every output file of a run into `out_dir` (see README for what each holds)."""
    with Staging(Path(out_dir)) as staging:
        stage_report(result, staging)
    return staging.written


def stage_report(result: RunResult, staging: Staging) -> None:
    """Write the report's files into a staging folder (they appear on its commit)."""
    config = result.config
    model, pft = config.model, config.roneld.pft
    staging.write_text("accuracy.csv", result.accuracy.to_csv(index=False, float_format="%.10g", lineterminator="\n"))
    comparison = tables.comparison_table(result.accuracy, model, pft)
    name = {"culane": "CULane", "tusimple": "TuSimple"}.get(result.dataset.name, result.dataset.name)
    staging.write_text("accuracy.md", f"# Accuracy on {name} ({model})\n\n" + comparison.to_markdown())
    staging.write_text("accuracy.tex", comparison.to_latex(
        f"Accuracy on {name} with {model} probability maps; Acc. Inc. is RONELD's increase, "
        f"in bold relative to the method it improves on.", f"tab:accuracy-{result.dataset.name}"))
    ablation = tables.ablation_table(result.accuracy, result.dataset.name)
    if ablation is not None:
        staging.write_text("ablation.md", f"# RONELD with and without PFT ({model})\n\n" + ablation.to_markdown())
        staging.write_text("ablation.tex", ablation.to_latex(
            f"Accuracy of {model} + RONELD with and without preceding frame tracking (PFT).",
            f"tab:pft-{result.dataset.name}"))
    staging.write_text("runtime.csv", result.runtime.to_csv(index=False, float_format="%.4f", lineterminator="\n"))
    staging.write_text("runtime.md", f"# Runtime per frame ({model})\n\n" + tables.runtime_table(
        result.runtime, model, pft).to_markdown())
    staging.write_text("per_frame.csv", result.per_frame.to_csv(index=False, float_format="%.10g", lineterminator="\n"))
    staging.write_text("official.csv", result.official.to_csv(index=False, float_format="%.6f", lineterminator="\n"))
    staging.write_text("config.toml", config.to_toml())
    staging.write_text("summary.json", json.dumps(summary(result), indent=2) + "\n")
    from .plots import accuracy_figure, save_figure  # matplotlib: imported only to draw

    figure = accuracy_figure(result.accuracy, model, result.dataset.name, pft)
    save_figure(figure, staging.file("accuracy_curve.png"), staging.file("accuracy_curve.svg"))
    if result.dataset.categories:
        from ..metrics.sweep import category_accuracy
        from .plots import category_figure

        threshold = config.official.iou_threshold
        by_category = category_accuracy(result.per_frame, result.dataset.categories, threshold, config.methods)
        staging.write_text("categories.csv", by_category.to_csv(index=False, float_format="%.6f", lineterminator="\n"))
        save_figure(category_figure(by_category, result.official, model, f"{threshold:g}", pft),
                    staging.file("categories.png"))
    from .html import build_html

    staging.write_text("report.html", build_html(staging.path))
