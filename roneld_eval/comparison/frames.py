"""`compare` of score folders written with `--diagnose`: the frames where one method beats the other
most, from their frames.csv.gz (a method's errors on a frame: its FP + FN there, at one threshold).

The two methods are the two (folder, method, matching) entries the folders hold together: one folder
scored with two methods, or two folders of one each. They must cover the same frames at the same
thresholds; anything else is refused in one line.
"""

from __future__ import annotations

import gzip
import io
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import numpy as np
import pandas as pd

from ..errors import InputError
from ..output import OutputFolder, Staging
from ..scoring import PlainTable

FRAMES = "frames.csv.gz"
KEYS = ["frame", "threshold"]
COMPARED_COLUMNS = ("frame", "sequence", "category", "threshold", "a_fp", "a_fn", "b_fp", "b_fn", "difference")


def is_diagnosed(folder: str | Path) -> bool:
    """A folder `score --diagnose` wrote (frames.csv.gz, no run's per_frame.csv)."""
    return (Path(folder) / FRAMES).is_file() and not (Path(folder) / "per_frame.csv").is_file()


@dataclass(frozen=True)
class FramesCompared:
    a: str  # the first method, as "folder: method (matching)"
    b: str
    rows: PlainTable  # COMPARED_COLUMNS, the frames where A makes fewer errors first
    markdown: str


def read_frames(folder: Path) -> pd.DataFrame:
    """A folder's frames.csv.gz, size bounded and checked to be the table `--diagnose` writes."""
    from ..lanes_io import read_bytes
    from ..limits import RUN_TABLE

    path = folder / FRAMES
    data = read_bytes(path, limit=RUN_TABLE)
    try:
        with gzip.GzipFile(fileobj=io.BytesIO(data)) as handle:
            text = handle.read(RUN_TABLE.bytes + 1)
        if len(text) > RUN_TABLE.bytes:
            raise InputError(path, f"unpacked, {RUN_TABLE.problem(len(text))}")
        table = pd.read_csv(io.BytesIO(text), dtype={"frame": str, "sequence": str, "category": str, "method": str,
                                                     "matching": str, "threshold": str}, keep_default_na=False)
    except (OSError, EOFError, ValueError, pd.errors.ParserError) as error:
        raise InputError(path, f"cannot read: {error}") from None
    needed = {"frame", "sequence", "category", "method", "matching", "threshold", "fp", "fn"}
    if not needed <= set(table.columns) or not _counts_hold(table):
        raise InputError(path, "not the frames.csv.gz of `score --diagnose` (frame, sequence, category, method, "
                               "matching, threshold, ..., fp, fn: counts that add up, or rates without tp)")
    return table


def _counts_hold(table: pd.DataFrame) -> bool:
    """fp and fn are counts below 2^40 whose error types add up to them (or, without a tp column,
    TuSimple's rates: finite, not negative)."""
    numbers = [c for c in ("tp", "fp", "fn") if c in table]
    if not all(pd.api.types.is_numeric_dtype(table[c]) for c in numbers):
        return False
    values = table[numbers].to_numpy(np.float64)
    if not (np.isfinite(values).all() and (values >= 0).all() and (values < 1 << 40).all()):
        return False
    return "tp" not in table or _types_add_up(table, numbers)


def _types_add_up(table: pd.DataFrame, numbers: list[str]) -> bool:
    """Integer counts, each side's error types (fp_*, fn_*) summing to it."""
    if not all(pd.api.types.is_integer_dtype(table[c]) for c in table.columns if c in numbers or "_" in c):
        return False
    sides = [[c for c in table.columns if c.startswith(f"{side}_")] for side in ("fp", "fn")]
    return all(not kinds or (table[kinds].sum(axis=1) == table[side]).all() for side, kinds in zip(("fp", "fn"), sides))


def compare_frames(folders: Sequence[str | Path], out: str | Path, top: int = 20) -> FramesCompared:
    """frames_compared.csv (every frame, A's advantage first) and frames_compared.md (the `top`
    frames each way) of the two methods the diagnosed score folders hold."""
    entries: dict[tuple[str, str, str], pd.DataFrame] = {}
    names = [Path(folder).name for folder in folders]
    for folder, name in zip(folders, names):
        table = read_frames(Path(folder))
        shown = name if len(set(names)) == len(names) else str(folder)
        for (method, matching), found in table.groupby(["method", "matching"], sort=False):
            entries[(shown, str(method), str(matching))] = found
    if len(entries) != 2:
        raise InputError(Path(folders[0]), f"compare lists the frames where one method beats another: these folders "
                                           f"hold {len(entries)} method{'s' if len(entries) != 1 else ''} "
                                           f"({', '.join(_name(e) for e in entries)}), not two")
    (a, rows_a), (b, rows_b) = entries.items()
    first, second = rows_a.set_index(KEYS), rows_b.set_index(KEYS)
    if first.index.has_duplicates or second.index.has_duplicates or set(first.index) != set(second.index):
        raise InputError(Path(folders[-1]), f"{_name(a)} and {_name(b)} are not scored on the same frames and "
                                            "thresholds: nothing to compare frame by frame")
    second = second.loc[first.index]
    joined = pd.DataFrame({"sequence": first["sequence"], "category": first["category"], "a_fp": first["fp"],
                           "a_fn": first["fn"], "b_fp": second["fp"], "b_fn": second["fn"]}).reset_index()
    joined["difference"] = (joined["b_fp"] + joined["b_fn"]) - (joined["a_fp"] + joined["a_fn"])
    joined = joined.sort_values("difference", ascending=False, kind="stable")
    listed = tuple(tuple(_plain(v) for v in row) for row in joined[list(COMPARED_COLUMNS)].itertuples(index=False))
    rows = PlainTable(COMPARED_COLUMNS, listed)
    compared = FramesCompared(_name(a), _name(b), rows, _markdown(_name(a), _name(b), rows, top))
    with OutputFolder(Path(out), "compare") as taken:
        staging = Staging(taken)
        staging.write_text("frames_compared.csv", compared.rows.to_csv())
        staging.write_text("frames_compared.md", compared.markdown)
        taken.commit()
    return compared


def _name(entry: tuple[str, str, str]) -> str:
    folder, method, matching = entry
    return f"{folder}: {method}" + (f" ({matching})" if matching else "")


def _plain(value):
    return value.item() if hasattr(value, "item") else value


def _markdown(a: str, b: str, compared: PlainTable, top: int) -> str:
    head = "| frame | category | threshold | A: FP, FN | B: FP, FN | B's errors - A's |"
    rule = "|---|---|---|---|---|---|"

    def lines(rows) -> list[str]:
        return [f"| {r[0]} | {r[2]} | {r[3]} | {r[4]:g}, {r[5]:g} | {r[6]:g}, {r[7]:g} | {r[8]:+g} |" for r in rows]

    ahead = [r for r in compared.rows if r[8] > 0][:top]
    behind = [r for r in reversed(compared.rows) if r[8] < 0][:top]
    return "\n".join([
        "# Frame by frame", "", f"A = {a}; B = {b}. A method's errors on a frame are its false "
        "positives plus false negatives there (frames.csv.gz of `score --diagnose`); every frame is in "
        "frames_compared.csv.", "", f"## Where A beats B most ({len(ahead)} shown)", "", head, rule, *lines(ahead), "",
        f"## Where B beats A most ({len(behind)} shown)", "", head, rule, *lines(behind), ""])
