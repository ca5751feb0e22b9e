"""`score tusimple`: Acc/FP/FN as TuSimple's evaluate/lane.py computes them, with the two F1
formulas papers print (roneld_eval.metrics.tusimple_official does the arithmetic)."""

from __future__ import annotations

import posixpath
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np


from ..errors import InputError
from ..output import Staging
from ..shards import Merged, Sharding

if TYPE_CHECKING:


    from ..metrics.tusimple_official import TusimpleScore
from ..score import _taking


def score_tusimple(labels: str | Path, pred: str | Path, out: str | Path | None = None, shard: str | None = None,
                   merged: Merged | None = None) -> TusimpleScore | None:
    """Score TuSimple JSON-lines predictions against a label file, as evaluate/lane.py does,
    with F1 under UFLD-v2's and CLRNet's formulas (f1_ufld, f1_clrnet). With `shard` ('I/N'),
    only that share of the clips (in label-file order), written as a part to `out` (None is
    returned); the part keeps each frame's scores and their lines, which a merge adds up in the
    prediction file's order, as lane.py does."""
    from ..metrics.tusimple_official import frame_scores, mean_scores, read_labels

    sharding = Sharding("score tusimple", shard, out, merged, dict(labels=labels, pred=pred),
                        paths=("labels", "pred"))
    with _taking(out, "score tusimple", reads=(labels, pred)) as folder:
        gts = read_labels(labels)
        keys, files = list(gts), [Path(labels), Path(pred)]
        if merged is not None:
            sharding.check_merged(keys, [], files, posixpath.dirname, files_of=None)  # pred: among `files`
            lines, _ = frame_scores(labels, pred, gts, checked_only=True)  # every line checked, none scored
            taken = sharding.merged_array("cat_line", (len(gts),), "i")
            # FP is below 0 where several labelled lanes match one prediction
            values = sharding.merged_array("cat_scores", (len(gts), 3), "f", within=(-1e6, 1e6))
            order = np.argsort(taken, kind="stable")
            if not np.array_equal(taken[order], np.array(lines, np.int64)):
                raise InputError(None, "the parts' frames are not the prediction file's lines: not its shards")
            scores = [(float(a), float(p), float(n)) for a, p, n in values[order].tolist()]
        else:
            share = sharding.share(keys, posixpath.dirname)  # a clip: a folder of frames
            lines, scores = frame_scores(labels, pred, gts, None if sharding.shard is None else frozenset(share))
            if sharding.shard is not None:
                assert folder is not None
                sharding.write_part(folder, keys, [], files, share,
                                    {"cat_line": np.array(lines, np.int64),
                                     "cat_scores": np.array(scores, np.float64).reshape(-1, 3)}, files_of=None)
                return None
        score = mean_scores(scores, len(gts))
        if folder is not None:
            import pandas as pd

            table = pd.DataFrame([score.as_row()])
            Staging(folder).write_csv("official.csv", table)
            folder.commit()
    return score
