"""`score tusimple`: Acc/FP/FN as TuSimple's evaluate/lane.py computes them, with the two F1
formulas papers print (roneld_eval.benchmarks.tusimple.official does the arithmetic). Several
prediction files are several methods, scored against one reading of the labels."""

from __future__ import annotations

import os
import posixpath
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Union, overload

import numpy as np


from ...errors import ConfigError, InputError
from ...output import Staging
from ...shards import Merged, Sharding, given_options

if TYPE_CHECKING:


    from .official import TusimpleScore
from ...scoring import PlainTable, _root_specs, _taking, check_method_names

COLUMNS = ("method", "accuracy", "fp", "fn", "f1_ufld", "f1_clrnet")

# Several prediction files: paths or 'NAME=FILE' (or (name, file) pairs), or a mapping of name to file.
PredictionFiles = Union[list, tuple, Mapping[str, Union[str, Path]]]


@overload
def score_tusimple(labels: str | Path, pred: str | Path, out: str | Path | None = None, shard: str | None = None,
                   merged: Merged | None = None, diagnose: bool = False) -> TusimpleScore | None: ...


@overload
def score_tusimple(labels: str | Path, pred: PredictionFiles, out: str | Path | None = None,
                   shard: str | None = None, merged: Merged | None = None,
                   diagnose: bool = False) -> dict[str, TusimpleScore] | None: ...


def score_tusimple(labels, pred, out=None, shard=None, merged=None, diagnose=False):
    """Score TuSimple JSON-lines predictions against a label file, as evaluate/lane.py does,
    with F1 under UFLD-v2's and CLRNet's formulas (f1_ufld, f1_clrnet). `pred`: one file (its
    score is returned), or several, each a method named by its file's stem or 'NAME=FILE' (a
    dict of method to score is returned); `out` gets official.csv, a row per method. With
    `shard` ('I/N'), only that share of the clips (in label-file order), written as a part to
    `out` (None is returned); the part keeps each frame's scores and their lines, which a merge
    adds up in each prediction file's order, as lane.py does. `diagnose`: also every frame's
    accuracy, FP and FN per method (frames.csv.gz; rates, so no error types)."""
    from .official import frame_scores, mean_scores, read_labels

    if diagnose and out is None:
        raise ConfigError("--diagnose writes frames.csv.gz: give --out")

    single = isinstance(pred, (str, Path))
    methods = _methods(pred)
    sharding = Sharding("score tusimple", shard, out, merged,
                        dict(labels=labels, pred=_recorded(pred), **given_options(diagnose=diagnose)),
                        paths=("labels",), roots=())
    with _taking(out, "score tusimple", reads=(labels, *methods.values())) as folder:
        gts = read_labels(labels)
        keys, files = list(gts), [Path(labels), *methods.values()]
        keys_of: list[list[str]] = []  # each method's frames in its file's order (--diagnose)
        if merged is not None:
            sharding.check_merged(keys, [], files, posixpath.dirname, files_of=None)  # pred: among `files`
            per_method = _merged_scores(sharding, labels, methods, gts, keys_of)
        else:
            share = sharding.share(keys, posixpath.dirname)  # a clip: a folder of frames
            scored = None if sharding.shard is None else frozenset(share)
            lines, per_method = [], []
            for path in methods.values():  # the labels read once, every method against them
                keys_of.append([])
                taken, frames = frame_scores(labels, path, gts, scored, keys=keys_of[-1])
                lines.append(taken)
                per_method.append(frames)
            if sharding.shard is not None:
                assert folder is not None
                sharding.write_part(folder, keys, [], files, share, {
                    "cat_line": np.array(lines, np.int64).reshape(len(methods), -1).T,
                    "cat_scores": np.array(per_method, np.float64).reshape(len(methods), -1, 3).transpose(1, 0, 2),
                }, files_of=None)
                return None
        means = {method: mean_scores(frames, len(gts)) for method, frames in zip(methods, per_method)}
        if folder is not None:
            staging = Staging(folder)
            staging.write_text("official.csv", official_table(means).to_csv())
            if diagnose:
                staging.write_bytes("frames.csv.gz", frames_csv_gz(list(methods), keys_of, per_method))
            folder.commit()
    return next(iter(means.values())) if single else means


FRAME_COLUMNS = ("frame", "sequence", "category", "method", "matching", "threshold", "accuracy", "fp", "fn")


def frames_csv_gz(methods: list[str], keys_of: list[list[str]], per_method: list[list]) -> bytes:
    """frames.csv.gz: each method's frames in its prediction file's order, lane.py's accuracy, FP
    and FN of each (a clip's folder as its sequence; no category, matching or IoU threshold)."""
    from ...output import csv_float, csv_gz

    return csv_gz(FRAME_COLUMNS, ((key, posixpath.dirname(key), "", method, "", "",
                                   *(csv_float(float(v)) for v in values))
                                  for method, keys, frames in zip(methods, keys_of, per_method)
                                  for key, values in zip(keys, frames)))


def official_table(scores: Mapping[str, TusimpleScore]) -> PlainTable:
    """official.csv: method, accuracy, fp, fn, f1_ufld, f1_clrnet (the columns of a run's TuSimple
    official.csv), a row per method."""
    return PlainTable(COLUMNS, tuple((method, *(float(v) for v in score.as_row().values()))
                                     for method, score in scores.items()))


def _methods(pred) -> dict[str, Path]:
    """Each method's prediction file: named by its stem, or as given ('NAME=FILE', a mapping)."""
    named = [(name or Path(path).stem, Path(path)) for name, path in _root_specs(pred)]
    check_method_names(named, "--pred NAME=FILE", "prediction files")
    return dict(named)


def _recorded(pred) -> str | list[str]:
    """The prediction files as a part records them: as given (one, or several), made absolute."""
    texts = [os.path.abspath(path) if name is None else f"{name}={os.path.abspath(path)}"
             for name, path in _root_specs(pred)]
    return texts[0] if isinstance(pred, (str, Path)) else texts


def _merged_scores(sharding: Sharding, labels, methods: Mapping[str, Path], gts: Mapping[str, dict],
                   keys_of: list[list[str]]) -> list[list]:
    """Each method's frame scores from the parts, in its prediction file's line order (each line's
    frame appended to `keys_of`, a list a method)."""
    from .official import frame_scores

    taken = sharding.merged_array("cat_line", (len(gts), len(methods)), "i")
    # FP is below 0 where several labelled lanes match one prediction
    values = sharding.merged_array("cat_scores", (len(gts), len(methods), 3), "f", within=(-1e6, 1e6))
    per_method = []
    for m, path in enumerate(methods.values()):
        keys_of.append([])
        lines, _ = frame_scores(labels, path, gts, checked_only=True, keys=keys_of[-1])  # every line checked
        order = np.argsort(taken[:, m], kind="stable")
        if not np.array_equal(taken[order, m], np.array(lines, np.int64)):
            raise InputError(None, "the parts' frames are not the prediction file's lines: not its shards")
        per_method.append([(float(a), float(p), float(n)) for a, p, n in values[order, m].tolist()])
    return per_method


__all__ = ["score_tusimple", "official_table", "COLUMNS"]
