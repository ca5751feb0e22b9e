"""What the `score` commands share: prediction trees found under roots (one method each, checked
before any work), scoring in pieces over worker processes, OUT taken first, and plain tables.
Each benchmark's scorer is its own module (benchmarks/<name>_score.py).
"""

from __future__ import annotations

import contextlib
import csv
import io
import os
import posixpath
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Callable, Iterator, Union

import numpy as np


from .datasets._paths import under_root
from .errors import ConfigError, InputError
from .lanes_io import check_folder
from .model import image_stem
from .output import OutputFolder, csv_float, refuse_cut_short
from .signals import terminate_as_interrupt

if TYPE_CHECKING:
    import pandas as pd




# a path or 'NAME=DIR'; several, or (name, folder) pairs among them; or a mapping of name to folder
PredictionRoots = Union[str, Path, Sequence[Union[str, Path, tuple]], Mapping[str, Union[str, Path]]]


@dataclass(frozen=True)
class PredictionTree:
    """One method's `.lines.txt` tree and how many of the listed frames have a file in it."""

    method: str
    root: Path
    found: int
    listed: int
    # Which listed files were there when the command looked (None where it did not look: a merge's
    # record): a file missing when scored is no lanes only if it was missing then too.
    seen: _Seen | None = field(default=None, compare=False, repr=False)


@dataclass(frozen=True)
class PlainTable:
    """A table as plain Python values (str, int, float; NaN where undefined): what a CSV file holds."""

    columns: tuple[str, ...]
    rows: tuple[tuple, ...]

    def to_csv(self) -> str:
        """The text pandas' `to_csv(index=False, lineterminator="\n")` writes for this table, byte
        for byte: floats as output.csv_float writes them (repr, NaN empty), csv's minimal quoting."""
        text = io.StringIO()
        # The dialect pandas hands csv.writer (pandas.io.formats.csvs), so that quoting is the same.
        writer = csv.writer(text, lineterminator="\n", delimiter=",", quoting=csv.QUOTE_MINIMAL, doublequote=True,
                            escapechar=None, quotechar='"')
        writer.writerow(self.columns)
        writer.writerows(tuple(_csv_cell(value) for value in row) for row in self.rows)
        return text.getvalue()

    def to_frame(self) -> pd.DataFrame:
        import pandas as pd

        return pd.DataFrame(list(self.rows), columns=list(self.columns))


def _csv_cell(value) -> object:
    # Every float column holds only floats (a NaN keeps it float), so formatting by value is by column.
    return csv_float(value) if isinstance(value, float) else value


class _ListedFiles:
    """The `.lines.txt` names the list asks for, grouped by folder, to find them under any root
    with one directory listing per folder (34,680 frames: 419 listings, not 34,680 stats)."""

    def __init__(self, relpaths: Sequence[str], suffix: str = ".lines.txt"):
        self.relpaths = relpaths
        self.suffix = suffix
        self.by_folder: dict[str, list[tuple[int, str]]] = {}
        for k, relpath in enumerate(relpaths):
            label = f"{image_stem(relpath)}{suffix}"
            # The name as the disk spells it, as under_root spells paths (UTF-8 whatever the locale).
            name = os.fsdecode(posixpath.basename(label).encode("utf-8", "surrogateescape"))
            self.by_folder.setdefault(posixpath.dirname(label), []).append((k, name))

    def present(self, root: Path) -> np.ndarray:
        """Which of the listed files are under `root` now, in list order."""
        there = np.zeros(len(self.relpaths), bool)
        for folder, names in self.by_folder.items():
            try:
                listing = set(os.listdir(under_root(root, folder) if folder else root))
            except (FileNotFoundError, NotADirectoryError):
                continue
            except OSError:
                listing = None  # there but unreadable: reading the files names the problem
            for k, name in names:
                there[k] = listing is None or name in listing
        return there

    def count(self, root: Path) -> int:
        return int(np.count_nonzero(self.present(root)))

    def first_missing(self, root: Path) -> Path:
        for relpath in self.relpaths:
            path = self.path(root, relpath)
            if not path.exists():
                return path
        return self.path(root, self.relpaths[0])

    def path(self, root: Path, relpath: str) -> Path:
        return under_root(root, f"{image_stem(relpath)}{self.suffix}")


@dataclass(frozen=True, eq=False)
class _Seen:
    """The listed files a tree held when the command looked."""

    files: _ListedFiles
    present: np.ndarray

    def vanished(self, root: Path) -> Path | None:
        """The first file that was there and is not now, or the root itself when it is gone."""
        if not root.is_dir():
            return root
        gone = np.flatnonzero(self.present & ~self.files.present(root))
        return self.files.path(root, self.files.relpaths[gone[0]]) if len(gone) else None


def check_still_there(trees: Sequence[PredictionTree]) -> None:
    """Refuse the scores where a prediction root, or a file in it, that was there when the command
    looked is gone now (a clean-up script removing old checkpoints while a sweep scores them): its
    frames were scored as frames without lanes, and the tables would say the file was there."""
    for tree in trees:
        gone = tree.seen.vanished(tree.root) if tree.seen is not None else None
        if gone is not None:
            what = "this prediction root" if gone == tree.root else "this prediction file"
            raise InputError(gone, f"{what} was removed while the command scored it (it was there when the "
                                   f"command looked): no result was written")


def _subfolders(root: Path) -> list[Path]:
    try:
        return sorted((Path(entry.path) for entry in os.scandir(root)
                       if entry.is_dir() and not entry.name.startswith(".")), key=lambda p: p.name)
    except OSError:
        return []


def listed_frames(listed: list[str], labels: Path, label_of: Callable[[Path, str], Path],
                  labels_word: str) -> list[str]:
    """`listed` (a list file's frames, or every labelled one), of which some must have their labels
    under `labels` (`label_of(labels, relpath)`): a folder holding none is the wrong folder."""
    if not any(label_of(labels, relpath).exists() for relpath in listed):
        raise ConfigError(f"no listed image has its {labels_word} under {labels} (first looked for: "
                          f"{label_of(labels, listed[0])})")
    return listed


def _root_specs(pred_root: PredictionRoots) -> list[tuple[str | None, Path]]:
    """(name or None, folder) of each root given: a path, 'NAME=DIR', a list of them, or a mapping."""
    if isinstance(pred_root, Mapping):
        return [(str(name), Path(path)) for name, path in pred_root.items()]
    if isinstance(pred_root, (str, Path)):
        pred_root = [pred_root]
    specs = [_root_spec(item) for item in pred_root]
    if not specs:
        raise ConfigError("give at least one prediction root")
    return specs


def _method_folders(root: Path, name: str | None, listed: _ListedFiles, option: str,
                    say: Callable[[str], None]) -> list[PredictionTree]:
    """A root's subfolders that mirror the list, one method each (as `run --save-lanes` writes
    OUT/lanes/<method>/); the others are said to be left out, and none is an error."""
    children, others = [], []
    for child in _subfolders(root):
        present = listed.present(child)
        if present.any():
            children.append(PredictionTree(f"{name}/{child.name}" if name else child.name, child,
                                           int(np.count_nonzero(present)), len(listed.relpaths),
                                           _Seen(listed, present)))
        else:
            others.append(child)
    if not children:
        raise _no_match(root, listed, option)
    for child in others:
        say(f"{child}: not a prediction tree (no file of the list), left out")
    return children


def _root_spec(item) -> tuple[str | None, Path]:
    """One root: a (name, folder) pair (a glob's match, or a part's record), 'NAME=DIR' (unless
    the whole text is itself an existing folder: a path may hold '='), or a folder."""
    if isinstance(item, (tuple, list)):
        if len(item) != 2 or not isinstance(item[1], (str, Path)) or not (item[0] is None or isinstance(item[0], str)):
            raise ConfigError(f"a prediction root given as a pair must be (name, folder), got {item!r}")
        return item[0] or None, Path(item[1])
    text = str(item)
    name, sep, folder = text.partition("=")
    if isinstance(item, str) and sep and name and "/" not in name and folder and not Path(text).exists():
        return name, Path(folder)
    return None, Path(item)


def _no_match(root: Path, listed: _ListedFiles, option: str = "--pred-root") -> InputError:
    """The one-line error for a root without any file of the list, with the folder that has them."""
    first = listed.path(root, listed.relpaths[0])
    hint = ""
    parent = root.parent if len(root.parts) > 1 else root.resolve().parent  # as the user wrote it, if possible
    if parent.resolve() != root.resolve() and listed.count(parent):
        hint = f"; did you mean {option} {parent} (it holds them)?"
    else:
        for child in _subfolders(root):
            methods = [grandchild.name for grandchild in _subfolders(child) if listed.count(grandchild)]
            if methods:
                hint = (f"; did you mean {option} {child} (its subfolders {', '.join(methods[:4])}"
                        f"{', ...' if len(methods) > 4 else ''} each hold them)?")
                break
    return InputError(root, f"no prediction file of the list is here (first looked for: {first}){hint}")


def find_prediction_trees(pred_root: PredictionRoots, relpaths: Sequence[str], strict: bool = False,
                          announce: Callable[[str], None] | None = None,
                          suffix: str = ".lines.txt", option: str = "--pred-root"
                          ) -> tuple[list[PredictionTree], list[str]]:
    """The methods to score and warnings about them, checked before any work.

    A root that mirrors the list is one method (named by its folder, or NAME=DIR); otherwise
    each of its subfolders that does is one (as `run --save-lanes` writes OUT/lanes/<method>/).
    A root with no file of the list at all is an error naming the path looked for and the
    folder that has them (one level up, or a folder of methods one level down). Fewer than
    half the listed files is a warning; with `strict`, any missing file is an error.
    """
    say = announce or (lambda message: None)
    listed = _ListedFiles(relpaths, suffix)
    trees: list[PredictionTree] = []
    for name, root in _root_specs(pred_root):
        refuse_cut_short(root)  # `run --save-lanes` killed while putting lanes/ in place
        check_folder(root, "prediction root not found")
        present = listed.present(root)
        if present.any():
            # named as given (a link to a checkpoint keeps its own name), "." and ".." made absolute first
            trees.append(PredictionTree(name or Path(os.path.abspath(root)).name, root,
                                        int(np.count_nonzero(present)), len(relpaths), _Seen(listed, present)))
            continue
        trees += _method_folders(root, name, listed, option, say)
    check_method_names([(tree.method, tree.root) for tree in trees], f"{option} NAME=DIR")
    warnings = []
    for tree in trees:
        missing = tree.listed - tree.found
        if strict and missing:
            raise InputError(tree.root, f"{missing:,} of {tree.listed:,} listed frames have no prediction file "
                                        f"(first: {listed.first_missing(tree.root)}); --strict needs every one")
        if tree.found * 2 < tree.listed:
            warnings.append(f"warning: {tree.root}: only {tree.found:,} of {tree.listed:,} listed frames have a "
                            f"prediction file; the other {missing:,} count as frames without lanes")
    return trees, warnings


def stopping_gaps(trees: Sequence[PredictionTree], listed: str = "listed images", file: str = "prediction file"
                  ) -> list[str]:
    """A warning for each method some of whose frames have no prediction file, for a benchmark whose
    evaluator stops on the first: here each is a frame without lanes."""
    return [f"warning: {tree.method}: {tree.listed - tree.found:,} of {tree.listed:,} {listed} have no {file}; "
            "scored as frames without lanes (the official evaluator stops on the first)"
            for tree in trees if tree.found < tree.listed]


def check_method_names(named: Sequence[tuple[str, Path]], naming: str, what: str = "prediction trees") -> None:
    """Each method's name, (name, where it comes from), is UTF-8 text (it goes into every table)
    and no other's; else the error says how to name them (`naming`: '--pred-root NAME=DIR')."""
    seen: dict[str, Path] = {}
    for method, where in named:
        try:
            method.encode("utf-8")
        except UnicodeEncodeError:
            kind = "folder's" if what == "prediction trees" else "file's"
            raise InputError(where, f"the {kind} name is not valid Unicode text (not UTF-8): rename it, "
                                    f"or name the method with {naming}") from None
        if method in seen:
            raise ConfigError(f"two {what} are named {method!r} ({seen[method]} and {where}): name them with "
                              f"{naming}")
        seen[method] = where


def only_frames(keys: Sequence[str], frames: Collection[str] | None, shard: str | None) -> list[str]:
    """The keys a scorer scores when it is given `frames` (a run's own: `run --diagnose`): those
    it lists that `frames` holds, in its order; all of them without."""
    if frames is None:
        return list(keys)
    if shard is not None:
        raise ConfigError("frames and a shard cut the list two ways: give one")
    wanted = set(frames)
    kept = [key for key in keys if key in wanted]
    if len(kept) != len(wanted):
        listed = set(kept)
        missing = next(frame for frame in frames if frame not in listed)
        raise ConfigError(f"frame {missing!r} is not among those listed")
    return kept


def scored_pieces(function: Callable, tasks: Sequence[tuple], workers: int | None, progress: bool,
                  announce: Callable[[str], None] | None = None, kernel_groups: tuple[str, ...] = ("official",),
                  unit: str = "frame", trees: Sequence[PredictionTree] = ()) -> list:
    """`function` over tasks whose first item is their frames, in order: in worker processes for
    more than one task (all cores unless `workers`), else here; a progress bar counts frames.
    The kernels are compiled once here first, not in every worker. The prediction `trees` read
    are checked to hold, once scored, every file they held when the command looked."""
    from .progress import progress_bar

    if kernel_groups:  # numba is imported only for them (a fifth of a second)
        from . import kernels

        kernels.prepare(announce=announce, needed=kernel_groups)
    from .workers import worker_count

    pieces = []
    with progress_bar(sum(len(task[0]) for task in tasks), unit, "scoring", wanted=progress) as bar:
        if len(tasks) > 1 and worker_count(workers) != 1:
            from .workers import process_pool, stopping

            died = "a worker process died (killed, or out of memory) while scoring: no result was written"
            with stopping(process_pool(min(worker_count(workers), len(tasks))), lambda: died) as pool:
                for task, piece in zip(tasks, pool.map(function, tasks)):
                    pieces.append(piece)
                    bar.update(len(task[0]))
        else:
            if kernel_groups:
                from . import kernels

                kernels.warm_up(kernel_groups)  # loaded here in one go, not frame by frame
            for task in tasks:
                pieces.append(function(task))
                bar.update(len(task[0]))
    check_still_there(trees)
    return pieces


@contextlib.contextmanager
def _taking(out: str | Path | None, command: str, reads: Sequence[str | Path | None] = ()
            ) -> Iterator[OutputFolder | None]:
    """The whole command with SIGTERM and SIGHUP ending it as Ctrl-C does, the inputs it `reads`
    refused where a killed command left them half in place, and OUT (when given) checked and
    locked before any work, not refused after it."""
    refuse_cut_short(*reads)
    with terminate_as_interrupt():
        if out is None:
            yield None
            return
        with OutputFolder(out, command) as folder:
            yield folder


def write_texts(folder: OutputFolder | None, texts: dict[str, str]) -> None:
    """A score command's files, written into its --out folder (when given) and put in place whole."""
    if folder is None:
        return
    from .output import Staging

    staging = Staging(folder)
    for name, text in texts.items():
        staging.write_text(name, text)
    folder.commit()


def percent(value: float) -> str:
    """A fraction as the summary tables print it: percent with 2 decimals, n/a for NaN."""
    return "n/a" if np.isnan(value) else f"{100 * value:.2f}"


__all__ = ["PlainTable", "PredictionTree", "check_still_there", "find_prediction_trees", "scored_pieces",
           "percent"]
