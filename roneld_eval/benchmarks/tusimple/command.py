"""`roneld-eval score tusimple`, declared (roneld_eval.score_commands builds the command)."""

from __future__ import annotations

from typing import Any, Mapping

from ...score_commands import Echo, Option, ScoreCommand, Sharding, out, quiet


def _one_or_several(values: dict[str, Any]) -> dict[str, Any]:
    """One file: its score, as the library gives it; several: one a method."""
    preds = values.pop("preds")
    return {**values, "pred": preds[0] if len(preds) == 1 else list(preds)}


def _report(score, values: Mapping[str, Any], echo: Echo) -> None:
    for method, one in (score.items() if isinstance(score, dict) else [("", score)]):
        echo(f"{f'{method}: ' if method else ''}{one.n_frames} frames: Accuracy {one.accuracy:.10g}  "
             f"FP {one.fp:.10g}  FN {one.fn:.10g}  F1 {one.f1_ufld:.10g} (UFLD-v2 lane2.py)  "
             f"{one.f1_clrnet:.10g} (CLRNet tusimple_metric.py)")


COMMAND = ScoreCommand(
    "tusimple",
    """Official TuSimple accuracy, FP and FN, as tusimple-benchmark's evaluate/lane.py computes them, and F1
    as UFLD-v2's lane2.py (f1_ufld) and CLRNet's tusimple_metric.py (f1_clrnet) compute it.""",
    options=(
        Option("--labels", "TuSimple label file (test_label.json).", kind="path", required=True),
        Option("--pred", "Predictions, one JSON object per line: raw_file, lanes, h_samples, optional run_time (ms). "
                         "One method, named by the file's stem or NAME. Repeatable: every method against one reading "
                         "of the labels.", name="preds", required=True, multiple=True, metavar="FILE|NAME=FILE"),
        out("Folder for official.csv: method, accuracy, fp, fn, f1_ufld, f1_clrnet (a row per method)."),
        Option("--diagnose", "Also every frame's accuracy, FP and FN per method (frames.csv.gz; TuSimple's FP and FN "
                             "are rates, so there are no lane error types). Needs --out.", kind="flag"),
        Sharding("clips"),
        quiet("Print nothing."),
    ),
    positional=("labels", "pred"),
    prepare=_one_or_several,
    report=_report,
    progress=False,
    quiet_says_nothing=True,
    keeps_collections=True,
)
