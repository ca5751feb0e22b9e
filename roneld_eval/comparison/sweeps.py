"""`compare` of checkpoint sweeps: folders that `score` wrote with several prediction roots
(sweep.csv, sweep.json), put side by side: every checkpoint of every sweep in one table, the best
of each named, and one figure of the headline score against the checkpoint.

Both files are untrusted input, checked field by field. Sweeps are compared only when sweep.json
says they were scored on the same frames (and categories), lane width and thresholds; with
`allow_mixed` other ones are, and every file says so.
"""

from __future__ import annotations

import csv
import io
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Mapping, Sequence

from ..errors import ConfigError, InputError
from ..json_fields import RepeatedKey, loads

SWEEP_CSV = "sweep.csv"
SWEEP_JSON = "sweep.json"
MAX_CHECKPOINTS = 100_000


@dataclass(frozen=True)
class SweepRow:
    method: str
    checkpoint: int | None
    scores: tuple[float, ...]  # fractions, in the sweep's columns order
    best: bool


@dataclass(frozen=True)
class Sweep:
    path: Path
    label: str
    command: str
    frames: int
    ground_truth: str
    width: int
    thresholds: tuple[str, ...]
    columns: tuple[str, ...]  # the headline scores, the last one choosing the best
    rows: tuple[SweepRow, ...]

    @property
    def best(self) -> SweepRow | None:
        return next((row for row in self.rows if row.best), None)


def is_sweep(folder: str | Path) -> bool:
    """A folder `score` wrote for several prediction roots (its sweep.csv is there)."""
    return (Path(folder) / SWEEP_CSV).is_file()


def _read(path: Path) -> str:
    from ..lanes_io import read_bytes
    from ..limits import TEXT

    try:
        return read_bytes(path, limit=TEXT).decode("utf-8")
    except UnicodeDecodeError:
        raise InputError(path, "not UTF-8 text: not a file roneld-eval wrote") from None


def read_sweep(folder: str | Path, label: str | None = None) -> Sweep:
    """A sweep's two files, every field checked (InputError naming the file and the problem)."""
    folder = Path(folder)
    if not folder.is_dir():
        raise InputError(folder, "not found" if not folder.exists() else "not a folder")
    record = _record(folder / SWEEP_JSON)
    columns = tuple(record["columns"])
    csv_path = folder / SWEEP_CSV
    rows = _rows(csv_path, columns)
    _check_best(csv_path, rows, record["best"], columns[-1])
    return Sweep(folder, label or folder.resolve().name, record["command"], record["frames"],
                 record["ground_truth"], record["width"], tuple(record["thresholds"]), columns, rows)


# sweep.json's fields and their types ("best": a checkpoint's name, or null)
_FIELDS = {"command": str, "version": str, "frames": int, "ground_truth": str, "width": int, "thresholds": list,
           "columns": list}


def _record(json_path: Path) -> dict:
    """sweep.json, its fields checked."""
    record = _json_of(json_path)
    from ..sweeps import SWEEP_FORMAT

    if not isinstance(record, dict) or record.get("format") != SWEEP_FORMAT:
        raise InputError(json_path, "not a sweep roneld-eval wrote")
    for key, kind in _FIELDS.items():
        if type(record.get(key)) is not kind:
            raise InputError(json_path, f"its {key!r} is missing or not {kind.__name__}")
    if not record["columns"] or not all(isinstance(c, str) and c for c in record["columns"] + record["thresholds"]):
        raise InputError(json_path, "its columns and thresholds are not lists of names")
    if "best" not in record or not (record["best"] is None or isinstance(record["best"], str)):
        raise InputError(json_path, "its 'best' is missing or not a checkpoint's name or null")
    if record["frames"] < 0 or record["width"] < 1:
        raise InputError(json_path, "its frames, width or best are not what score writes")
    return record


def _json_of(json_path: Path):
    if not json_path.is_file():
        raise InputError(json_path, "missing: a sweep written by this version of `roneld-eval score` has it "
                                    "beside sweep.csv (score the checkpoints again)")
    try:
        return loads(_read(json_path))
    except RepeatedKey as error:
        raise InputError(json_path, str(error)) from None
    except json.JSONDecodeError as error:
        raise InputError(json_path, f"not JSON ({error.msg}, line {error.lineno})") from None
    except (ValueError, RecursionError) as error:  # a 5,000-digit number; arrays nested 100,000 deep
        raise InputError(json_path, f"not JSON roneld-eval wrote: {str(error).splitlines()[0]}") from None


def _check_best(csv_path: Path, rows: tuple[SweepRow, ...], recorded: str | None, last_column: str) -> None:
    """The checkpoint sweep.csv marks best is sweep.json's, and the one of the highest last column."""
    best = [row.method for row in rows if row.best]
    if best != ([] if recorded is None else [recorded]):
        raise InputError(csv_path, f"its best checkpoint ({', '.join(best) or 'none'}) is not sweep.json's "
                                   f"({recorded})")
    if best:
        top = max((row.scores[-1] for row in rows if not math.isnan(row.scores[-1])), default=None)
        if next(row for row in rows if row.best).scores[-1] != top:
            raise InputError(csv_path, f"the checkpoint marked best is not the one of the highest {last_column}")


def _rows(path: Path, columns: tuple[str, ...]) -> tuple[SweepRow, ...]:
    lines = list(csv.reader(io.StringIO(_read(path))))
    header = ["method", "checkpoint", *columns, "best"]
    if not lines or lines[0] != header:
        raise InputError(path, f"its header is not {','.join(header)}")
    rows: list[SweepRow] = []
    seen: set[str] = set()
    for number, line in enumerate(lines[1:], start=2):
        if len(line) != len(header):
            raise InputError(path, f"{len(line)} fields where the header has {len(header)}", line=number)
        rows.append(_row(path, number, line, seen))
        seen.add(line[0])
    if not rows or len(rows) > MAX_CHECKPOINTS:
        raise InputError(path, f"holds {len(rows):,} checkpoints (1 to {MAX_CHECKPOINTS:,})")
    return tuple(rows)


def _row(path: Path, number: int, line: list[str], seen: set[str]) -> SweepRow:
    """One checkpoint's line: its name (not among those `seen`), number, scores in [0, 1] (or
    NaN) and whether it is best."""
    method, checkpoint, *scores, best = line
    if not method or method in seen or any(ord(c) < 32 for c in method):
        raise InputError(path, f"a checkpoint name that is empty, repeated or holds control characters "
                               f"({method[:60]!r})", line=number)
    try:
        values = tuple(float(v) for v in scores)
        number_of = None if checkpoint == "" else int(checkpoint)
    except ValueError:
        raise InputError(path, "a score or checkpoint that is not a number", line=number) from None
    if not all(math.isnan(v) or 0 <= v <= 1 for v in values) or best not in ("True", "False"):
        raise InputError(path, "a score outside [0, 1] or a best that is not True/False", line=number)
    return SweepRow(method, number_of, values, best == "True")


@dataclass(frozen=True)
class SweepComparison:
    sweeps: tuple[Sweep, ...]
    notes: tuple[str, ...]
    files: tuple[Path, ...]


def compare_sweeps(folders: Sequence[str | Path], out: str | Path, labels: Mapping[str | Path, str] | None = None,
                   allow_mixed: bool = False) -> SweepComparison:
    """sweeps.csv, sweeps.md and sweeps.png of these sweeps into `out`."""
    from ..output import OutputFolder, Staging
    from ..signals import terminate_as_interrupt
    from .comparable import run_labels

    with terminate_as_interrupt(), OutputFolder(out, "compare") as folder:
        chosen = run_labels(folders, labels or {})
        sweeps = tuple(read_sweep(path, chosen.get(k)) for k, path in enumerate(folders))
        names = [sweep.label for sweep in sweeps]
        twice = sorted({name for name in names if names.count(name) > 1})
        if twice:
            raise ConfigError(f"two sweeps are labelled {twice[0]!r}: name them with --label DIR=LABEL")
        notes = tuple(_comparable(sweeps, allow_mixed))
        staging = Staging(folder)
        staging.write_text("sweeps.csv", _table_csv(sweeps))
        staging.write_text("sweeps.md", _markdown(sweeps, notes))
        _figure(sweeps, staging.file("sweeps.png"), notes)
        written = folder.commit()
    return SweepComparison(sweeps, notes, tuple(written))


def _comparable(sweeps: Sequence[Sweep], allow_mixed: bool) -> list[str]:
    first = sweeps[0]
    notes = []
    for sweep in sweeps[1:]:
        if sweep.columns[-1] != first.columns[-1]:
            raise ConfigError(f"{sweep.path} chooses its best by {sweep.columns[-1]}, {first.path} by "
                              f"{first.columns[-1]}: score the sweeps with the same --iou")
        for what, mine, theirs in (("command", sweep.command, first.command),
                                   ("frames (the list and its categories)", sweep.ground_truth, first.ground_truth),
                                   ("lane width", sweep.width, first.width),
                                   ("thresholds", sweep.thresholds, first.thresholds)):
            if mine != theirs:
                said = f"{sweep.path} and {first.path} differ in their {what}"
                if not allow_mixed:
                    raise ConfigError(f"{said}: their scores are not comparable (--allow-mixed compares them "
                                      "anyway, with a note)")
                notes.append(f"{said}: compared anyway (--allow-mixed)")
    return notes


def _cell(value: float) -> str:
    from ..output import csv_float

    return csv_float(value)  # as read from sweep.csv: the same text


def _table_csv(sweeps: Sequence[Sweep]) -> str:
    columns = list(dict.fromkeys(c for sweep in sweeps for c in sweep.columns))
    text = io.StringIO()
    writer = csv.writer(text, lineterminator="\n")
    writer.writerow(["sweep", "method", "checkpoint", *columns, "best"])
    for sweep in sweeps:
        for row in sweep.rows:
            values = dict(zip(sweep.columns, row.scores))
            writer.writerow([sweep.label, row.method, "" if row.checkpoint is None else row.checkpoint,
                             *(_cell(values.get(c, math.nan)) for c in columns), row.best])
    return text.getvalue()


def _markdown(sweeps: Sequence[Sweep], notes: Sequence[str]) -> str:
    from ..scoring import percent

    columns = list(sweeps[0].columns)
    lines = ["# Checkpoint sweeps", "",
             f"The best checkpoint of each sweep by {columns[-1]} over all frames, chosen on the frames scored "
             "(a test-set choice unless they are a validation split). "
             f"{_configuration(sweeps[0])}", ""]
    lines += [f"Note: {note}." for note in notes] + ([""] if notes else [])
    lines += ["| sweep | checkpoints | best | " + " | ".join(f"{c} (%)" for c in columns) + " |",
              "|---" * (3 + len(columns)) + "|"]
    for sweep in sweeps:
        best = sweep.best
        values = dict(zip(sweep.columns, best.scores)) if best is not None else {}
        lines.append(f"| {sweep.label} | {len(sweep.rows)} | {best.method if best else 'n/a'} | "
                     + " | ".join(percent(values.get(c, math.nan)) for c in columns) + " |")
    return "\n".join(lines) + "\n"


def _configuration(sweep: Sweep) -> str:
    thresholds = sweep.thresholds
    grid = thresholds[0] if len(thresholds) == 1 else \
        f"{thresholds[0]}..{thresholds[-1]} ({len(thresholds)} thresholds)"
    return f"`{sweep.command}`: {sweep.frames:,} frames, lanes {sweep.width} px wide, IoU {grid}."


def _figure(sweeps: Sequence[Sweep], path: Path, notes: Sequence[str]) -> None:
    """The deciding score against the checkpoint, one line a sweep, each best starred; the legend
    outside the axes, inside the canvas."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..report.figure_files import write_png

    column = sweeps[0].columns[-1]
    numbered = all(row.checkpoint is not None for sweep in sweeps for row in sweep.rows)
    figure, axes = plt.subplots(figsize=(8, 4.2), dpi=100, layout="constrained")
    for sweep in sweeps:
        xs = [float(row.checkpoint if numbered and row.checkpoint is not None else k)
              for k, row in enumerate(sweep.rows)]
        ys = [100 * row.scores[-1] for row in sweep.rows]
        (line,) = axes.plot(xs, ys, marker="o", markersize=3, label=sweep.label)
        for x, row in zip(xs, sweep.rows):
            if row.best:
                axes.plot([x], [100 * row.scores[-1]], marker="*", markersize=13, color=line.get_color(),
                          markeredgecolor="black", linestyle="none",
                          label=f"best of {sweep.label}: {row.method} ({100 * row.scores[-1]:.2f})")
    if numbered:
        from matplotlib.ticker import MaxNLocator

        axes.xaxis.set_major_locator(MaxNLocator(integer=True))
    axes.set_xlabel("checkpoint (the number in its name)" if numbered else "checkpoint (in each sweep's order)")
    axes.set_ylabel(f"{column} (%)")
    axes.set_title(f"{column} over all frames\n{_configuration(sweeps[0])}"
                   + (" Mixed settings: see sweeps.md." if notes else ""), fontsize=9)
    axes.grid(alpha=0.3)
    figure.legend(loc="outside right upper", fontsize=8)
    write_png(figure, path)
    plt.close(figure)
