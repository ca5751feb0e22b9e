"""Many checkpoints in one `score`: prediction roots from a glob or a list file, named by what
tells them apart (epoch_12, seed3/epoch_40), and the sweep they make: one row per checkpoint of
the headline scores over all frames, the best one named, and a plot of each against the checkpoint.
"""

from __future__ import annotations

import glob
import math
import os
import re
import textwrap
from pathlib import Path
from typing import Mapping, NamedTuple, Sequence

from .errors import ConfigError, InputError

_WILDCARD = re.compile(r"[*?\[]")
SWEEP_FORMAT = "roneld-eval sweep"


class Checkpoint(NamedTuple):
    """A prediction root of a checkpoint sweep (a glob's match, a line of a list file): its name
    (None: named by what tells its path apart from the sweep's other checkpoints) and folder."""

    name: str | None
    folder: str


def expand_roots(specs: Sequence) -> list:
    """--pred-root values with glob patterns replaced by the folders they match, sorted in natural
    order, each a Checkpoint; then every unnamed Checkpoint (a list file's too) named by
    `checkpoint_names`. Any other value (an existing path, NAME=DIR, a pair) is kept as it is; a
    pattern matching no folder is an error."""
    out: list = []
    for spec in specs:
        text = str(spec)
        if isinstance(spec, (tuple, list)) or not _WILDCARD.search(text) or Path(text).exists():
            out.append(spec)
            continue
        matches = sorted((Path(m) for m in glob.glob(text) if Path(m).is_dir()), key=lambda p: natural_key(str(p)))
        if not matches:
            raise InputError(Path(text), "no folder matches this pattern")
        out += [Checkpoint(None, str(match)) for match in matches]
    names = checkpoint_names([spec.folder for spec in out if isinstance(spec, Checkpoint)])
    return [spec._replace(name=spec.name or names[spec.folder]) if isinstance(spec, Checkpoint) else spec
            for spec in out]


def is_sweep(specs: Sequence) -> bool:
    """Whether prediction roots hold a checkpoint sweep (a glob, a list file), not only methods."""
    return any(isinstance(spec, Checkpoint) for spec in specs)


def checkpoint_names(folders: Sequence[str]) -> dict[str, str]:
    """Each folder's name in its sweep: the parts of its path between those all the sweep's
    folders share at the start and at the end ('work_dirs/epoch_12/lines' among other epochs:
    'epoch_12'; 'seed3/epoch_40' where seeds differ too), however the folders were given (a glob,
    a list file, relative or absolute paths); a sweep of one folder: its folder's name. Distinct
    folders get distinct names: they share the parts left out."""
    paths = {folder: Path(os.path.abspath(folder)).parts for folder in folders}  # links not followed
    if not paths:
        return {}
    distinct = set(paths.values())
    shortest = min(len(parts) for parts in distinct)
    lead = 0
    while lead < shortest - 1 and len({parts[lead] for parts in distinct}) == 1:
        lead += 1
    trail = 0
    while trail < shortest - lead - 1 and len({parts[-1 - trail] for parts in distinct}) == 1:
        trail += 1
    return {folder: "/".join(parts[lead:len(parts) - trail]) for folder, parts in paths.items()}


def roots_from_file(path: str | Path) -> list:
    """A list file of prediction roots: one 'DIR' or 'NAME=DIR' a line ('#' comment lines and blank
    lines skipped), each a Checkpoint; a relative DIR is relative to the file's folder, and a DIR
    without a name is named as a glob's match is (`expand_roots`)."""
    from .lanes_io import read_text

    path = Path(path)
    roots: list = []
    for number, line in enumerate(read_text(path).splitlines(), start=1):
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        name, equals, folder = line.partition("=")
        if equals and not Path(path.parent / line).exists() and (not name.strip() or "/" in name
                                                                 or not folder.strip()):
            raise InputError(path, f"{line!r} is neither DIR nor NAME=DIR", line=number)
        if equals and Path(path.parent / line).exists():  # a folder whose name holds '='
            equals, folder = "", line
        folder = folder.strip() if equals else line
        where = Path(folder) if Path(folder).is_absolute() else path.parent / folder
        roots.append(Checkpoint(name.strip() if equals else None, str(where)))
    if not roots:
        raise ConfigError(f"{path}: lists no prediction root")
    return roots


def natural_key(text: str) -> list:
    """'epoch_9' before 'epoch_10': digits compared as numbers."""
    return [(0, int(part), "") if part.isdigit() else (1, 0, part) for part in re.split(r"([0-9]+)", text)]


def checkpoint_number(name: str) -> int | None:
    """The last number in a checkpoint's name (epoch_12 -> 12), or None."""
    numbers = re.findall(r"[0-9]+", name)
    return int(numbers[-1]) if numbers else None


def sweep_table(methods: Sequence[str], columns: Sequence[str], values: Mapping[str, Sequence]):
    """sweep.csv: (method, checkpoint, each headline score, best) in checkpoint order, where every
    name holds a number (else in the given order); the best is the highest last score (mF1 where
    a grid was scored), the first such checkpoint on ties. `values[method]` is in `columns` order."""
    from .scoring import PlainTable

    numbers = {method: checkpoint_number(method) for method in methods}
    ordered = list(methods)
    if all(n is not None for n in numbers.values()):
        ordered = sorted(methods, key=lambda m: (numbers[m], natural_key(m)))
    scores = {method: float(values[method][-1]) for method in methods}
    finite = [m for m in ordered if not math.isnan(scores[m])]
    best = max(finite, key=lambda m: scores[m]) if finite else None
    rows = tuple((method, "" if numbers[method] is None else numbers[method], *(float(v) for v in values[method]),
                  method == best) for method in ordered)
    return PlainTable(("method", "checkpoint", *columns, "best"), rows), best


def ego_lanes_note(methods: Sequence[str]) -> str:
    """What a best named among methods of which some output the ego lanes alone does not say: their
    F1 counts every other lane as missed (a run's lanes/ folder holds RONELD's beside the baseline's)."""
    from .config import EGO_LANES_ONLY
    from .wording import ego_lanes_only

    ego_only = [method for method in methods if method in EGO_LANES_ONLY]
    if not ego_only or len(ego_only) == len(methods):
        return ""
    return f"{ego_lanes_only(ego_only)}: F1 over all lanes counts the outer lanes as missed"


def plot_sweep(table, path: Path, title: str) -> None:
    """sweep.png: each headline score (in percent) against the checkpoint, the best one marked."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .report.figure_files import write_png

    columns = table.columns[2:-1]
    note = ego_lanes_note([row[0] for row in table.rows])
    numbered = all(row[1] != "" for row in table.rows)
    xs = [row[1] if numbered else k for k, row in enumerate(table.rows)]
    figure, axes = plt.subplots(figsize=(7, 4), dpi=100)
    for c, column in enumerate(columns):
        axes.plot(xs, [100 * row[2 + c] for row in table.rows], marker="o", markersize=3, label=column)
    for x, row in zip(xs, table.rows):
        if row[-1]:
            axes.plot([x], [100 * row[-2]], marker="*", markersize=14, color="black", linestyle="none",
                      label=f"best {columns[-1]} on these frames: {row[0]} ({100 * row[-2]:.2f})"
                      + "".join(f"\n{line}" for line in textwrap.wrap(note, 60)))
    axes.set_xlabel("checkpoint (the number in its name)" if numbered else "checkpoint")
    if not numbered:
        axes.set_xticks(xs, [row[0] for row in table.rows], rotation=45, ha="right", fontsize=7)
    axes.set_ylabel("%")
    axes.set_title(title, fontsize=10)
    axes.grid(alpha=0.3)
    axes.legend(fontsize=8, loc="lower right")
    figure.tight_layout()
    write_png(figure, path)
    plt.close(figure)
