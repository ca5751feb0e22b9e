"""Deterministic perturbed TuSimple predictions of a label file, for the F1 golden test.

The golden values in golden/tusimple_f1.json came from running UFLD-v2's lane2.py and
CLRNet's tusimple_metric.py on exactly these predictions. Standard library only (the same
file ran in the throwaway environment that ran those scripts), and only
random.Random.random(), whose sequence Python guarantees for a given seed.
"""

from __future__ import annotations

import hashlib
import json
import random
from typing import Iterable

# (drop a lane, add a false lane, run over 200 ms, more than gt + 2 lanes, typical shift in px)
SEVERITIES = {
    "mild": (0.04, 0.06, 0.0, 0.0, 6.0),
    "harsh": (0.15, 0.35, 0.03, 0.03, 16.0),
}


def perturbed_predictions(label_lines: Iterable[str], seed: int, severity: str) -> str:
    """JSON lines (raw_file, lanes, h_samples, run_time): each label's lanes shifted, tilted,
    jittered, cut short or extended, some dropped, false lanes added, order shuffled."""
    drop, false_lane, slow, crowd, shift_px = SEVERITIES[severity]
    u = random.Random(seed).random
    out = []
    for line in label_lines:
        if not line.strip():
            continue
        record = json.loads(line)
        rows = record["h_samples"]
        as_float = u() < 0.3  # some methods write floats, most write integers
        lanes = []
        for gt in record["lanes"]:
            if u() < drop:
                continue
            scale = shift_px * (1 if u() < 0.7 else 3 if u() < 0.8 else 8)
            shift = (u() - 0.5) * 2 * scale
            tilt = (u() - 0.5) * 0.4  # px per row
            valid = [k for k, x in enumerate(gt) if x >= 0]
            cut = int(u() * len(valid) * 0.4) if u() < 0.2 else 0  # the far end not found
            extend = u() < 0.1  # the far end drawn beyond the label
            lane = []
            for k, x in enumerate(gt):
                if x < 0 or k in valid[:cut]:
                    if extend and valid and k < valid[0] and k >= valid[0] - 4:
                        x = gt[valid[0]]
                    else:
                        lane.append(-2)
                        continue
                value = x + shift + tilt * k + (u() - 0.5) * 4
                lane.append(round(value, 2) if as_float else int(round(value)))
            lanes.append(lane)
        if u() < false_lane:
            x0 = 100 + u() * 1080
            lanes.append([round(x0 + (u() - 0.5) * 3) if y >= 300 else -2 for y in rows])
        if u() < crowd:
            while len(lanes) <= len(record["lanes"]) + 2:
                lanes.append([round(640 + 50 * len(lanes)) for _ in rows])
        if u() < 0.5:
            lanes.reverse()
        run_time = 250 if u() < slow else int(5 + u() * 40)
        out.append(json.dumps({"raw_file": record["raw_file"], "lanes": lanes, "h_samples": rows,
                               "run_time": run_time}))
    return "".join(line + "\n" for line in out)


def digest(text: str) -> str:
    return hashlib.sha256(text.encode("utf-8")).hexdigest()
