"""The whole evaluation: read a dataset, load each clip's maps, extract lanes with every method,
score them, and return one `RunResult`. Writes nothing itself (see report.write).

A clip is the unit of state (RONELD's tracking) and of parallel work: `evaluate_clip` runs in
worker processes and returns plain per-frame records; they are merged in clip order, so any
number of workers gives the same result. Lanes to save stream to a `lane_sink` as clips finish,
so memory stays flat in the number of frames.

The stages, one module each: records, plan, one_clip, plugin_call, pool, tables.
"""

from __future__ import annotations

import time
from array import array
from typing import Callable, Sequence


from .. import kernels
from ..benchmarks import Benchmark, OfficialTally
from ..config import EvalConfig
from ..thresholds import parse_thresholds
from ..metrics.sweep import sweep_accuracy
from ..model import Clip, Dataset, Frame
from ..progress import progress_bar
from ..workers import default_workers, worker_count
from .one_clip import effective_geometry, evaluate_clip
from .plan import RunPlan, check_maps, describe_missing, plan
from .pool import ClipCache, _clip_results, clip_inputs
from .records import ClipResult, FrameOutcome, PerFrameRows, RunContext, RunResult
from .tables import PairedGains, _runtime_table, pairwise_gains, versions, with_intervals


def evaluate(
    config: EvalConfig,
    benchmark: Benchmark,
    progress: bool = True,
    lane_sink: Callable[[FrameOutcome, Frame], None] | None = None,
    dataset: Dataset | None = None,
    cache: ClipCache | None = None,
    announce: Callable[[str], None] | None = None,
    shard=None,
    meanwhile: Callable[[], object] | None = None,
) -> RunResult:
    """Evaluate every configured method on a dataset's stored maps (the library `run`).

    With on_error = "skip", bad label lines, bad map files and clips with missing maps are
    left out and listed in `RunResult.skipped`; otherwise the first one raises InputError
    before anything is computed (maps' contents are checked as they load). `meanwhile()` is
    called once while the worker processes warm up, where this process would only wait (`run`
    imports the report's libraries); not when the clips are evaluated in this process.
    """
    started = time.perf_counter()
    planned = plan(config, benchmark, dataset, announce, shard)
    clips, context = list(planned.clips), planned.context
    # Compiled once here, before the workers fork, instead of in every worker at once; in as
    # many processes as asked, even where a small run then evaluates in fewer (pool_size).
    processes = min(worker_count(config.workers), max(len(clips), 1))
    kernels.prepare(announce=announce or (lambda message: None), needed=context.kernel_groups(), processes=processes)
    merged = _Merged(config, benchmark.tally(config.methods, planned.dataset, config), planned.skipped)
    with progress_bar(sum(len(clip.frames) for clip in clips), "frame", "evaluating", wanted=progress) as bar:
        results = _clip_results(clips, context, config.workers, cache, advance=bar.update, meanwhile=meanwhile)
        for clip, result in zip(clips, results, strict=True):  # strict: runs the generator to its end
            merged.add(clip, result, lane_sink)
            del result

    per_frame = merged.rows.take_table()
    thresholds = parse_thresholds(config.paper.thresholds)
    paired = PairedGains(per_frame, thresholds)
    merged.totals["ego_lanes"] = int(len(per_frame) // max(len(config.methods), 1))
    geometry = planned.geometry
    notes = []
    if merged.map_sizes:
        geometry = effective_geometry(config, *next(iter(merged.map_sizes)), planned.dataset.frame_sizes)
        if len(merged.map_sizes) > 1:
            notes.append("maps differ in size between clips (each clip is rescaled by its own): " + ", ".join(
                f"{w}x{h} from clip {clip_id}" for (w, h), clip_id in merged.map_sizes.items()))
        notes.extend(dict.fromkeys(filter(None, (config.paper.other_rule_note(w, h) for w, h in merged.map_sizes))))
    return RunResult(
        config=config,
        benchmark=benchmark,
        dataset=planned.dataset,
        per_frame=per_frame,
        accuracy=with_intervals(sweep_accuracy(per_frame, thresholds, methods=config.methods), paired),
        official=merged.tally.table(),
        runtime=_runtime_table(merged.extract_ms, merged.load_ms),
        counts=merged.totals,
        wall_time_s=time.perf_counter() - started,
        skipped=merged.skipped,
        versions=versions(),
        geometry=geometry,
        gains=pairwise_gains(paired, config.methods),
        notes=notes,
    )


class _Merged:
    """What the main process keeps of the clips' results as they arrive in clip order: compact
    per-frame rows, the official tally, timings, counts and skips (not the workers' records, so
    it stays small however long the run)."""

    def __init__(self, config: EvalConfig, tally: OfficialTally, skipped: Sequence[str]):
        self.rows = PerFrameRows()
        self.tally = tally
        self.extract_ms = {method: array("d") for method in config.methods}
        self.load_ms = array("d")
        self.totals = dict(clips=0, frames=0, labelled_frames=0, gt_lanes=0)
        self.map_sizes: dict[tuple[int, int], str] = {}
        self.skipped = list(skipped)

    def add(self, clip: Clip, result: ClipResult, lane_sink: Callable[[FrameOutcome, Frame], None] | None) -> None:
        if result.map_size is not None:
            self.map_sizes.setdefault(result.map_size, result.clip_id)
        self.totals["clips"] += 1
        self.totals["frames"] += result.n_frames
        self.totals["labelled_frames"] += result.n_scored
        self.totals["gt_lanes"] += result.n_gt_lanes
        for method, values in result.extract_ms.items():
            self.extract_ms[method].extend(values)
        self.load_ms.extend(result.load_ms)
        self.skipped.extend(result.skipped)
        # The frames as read here: what a lane file needs of its frame (its benchmark's label
        # rows, say), and the relpath strings kept (not the workers' copies, which would each stay).
        listed = {frame.relpath: frame for frame in clip.frames}
        for outcome in result.outcomes:
            frame = listed[outcome.relpath]
            if lane_sink is not None:
                lane_sink(outcome, frame)
            self.rows.add(frame.relpath, outcome)
            self.tally.add(outcome.method, frame.relpath, outcome.official)
        self.tally.end_clip(clip.clip_id)




__all__ = ["evaluate", "plan", "RunPlan", "RunResult", "RunContext", "ClipResult", "FrameOutcome", "PerFrameRows",
           "ClipCache", "evaluate_clip", "effective_geometry", "check_maps", "describe_missing", "clip_inputs",
           "versions", "default_workers"]
