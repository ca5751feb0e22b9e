"""`score openlane3d` beside OpenLane's own lane3d evaluator on the same files, side by side.

Generates a set with `synth --dataset openlane3d` (--frames of them, 10 a segment), then times,
interleaved so that a change in the machine's load falls on both alike, fresh processes of the
official evaluator (eval_3D_lane.py at OpenDriveLab/OpenLane 8a0ce6b, run by a Python that has
its old stack: numpy<1.24, scipy, ortools 9.3; given by path, never part of this repository) and
of `roneld-eval score openlane3d --workers 1`. Prints the medians of wall and CPU time, their
ratios, and whether both printed the same eight numbers. The target (issue: 3-D lanes) is at
least 20x less CPU, and the 40,000 frames of the validation split in under a minute on 2 cores.

    python scripts/bench_openlane3d.py --official-python /path/venv/bin/python \\
        --lane3d /path/OpenLane/eval/LANE_evaluation/lane3d [--frames 2000] [--repeats 5]

The official file crashes at that commit (LaneEval.bench reads self.dataset_name, never set), so it
is run through a few lines that set it to 'openlane' and call bench_one_submit as its __main__ does.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from side_by_side import interleaved, timed  # noqa: E402

RUNNER = """
import sys
sys.path.insert(0, {lane3d!r})
import eval_3D_lane as official
from utils.utils import define_args
args = define_args().parse_args(['--dataset_dir', {labels!r}, '--pred_dir', {preds!r}, '--test_list', {listed!r}])
evaluator = official.LaneEval(args)
evaluator.dataset_name = 'openlane'
stats = evaluator.bench_one_submit(args.pred_dir, args.dataset_dir, args.test_list, prob_th=0.5)
print(' '.join('{{:.8}}'.format(v) for v in stats[:8]))
"""


def ours_printed(text: str) -> str:
    row = next(line for line in text.splitlines() if line.startswith("| ") and "| all |" in line)
    return " ".join(cell.strip() for cell in row.strip("|").split("|")[2:])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--official-python", required=True, help="a Python with numpy<1.24, scipy and ortools 9.3")
    parser.add_argument("--lane3d", required=True, help="OpenLane's eval/LANE_evaluation/lane3d folder")
    parser.add_argument("--frames", type=int, default=2000)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="roneld-bench-openlane3d-") as folder:
        root = Path(folder)
        subprocess.run([sys.executable, "-m", "roneld_eval", "synth", "--dataset", "openlane3d", "--out",
                        str(root / "set"), "--clips", str(max(1, args.frames // 10)), "--frames", "10"],
                       check=True, capture_output=True)
        labels, preds, listed = root / "set" / "labels", root / "set" / "predictions", root / "set" / "test_list.txt"
        runner = root / "official.py"
        runner.write_text(RUNNER.format(lane3d=str(Path(args.lane3d).resolve()), labels=f"{labels}/",
                                        preds=f"{preds}/", listed=str(listed)))
        cases = {
            "official eval_3D_lane.py": [args.official_python, "-W", "ignore", str(runner)],
            "roneld-eval score openlane3d": [sys.executable, "-m", "roneld_eval", "score", "openlane3d", "--labels",
                                             str(labels), "--pred-root", str(preds), "--list", str(listed),
                                             "--workers", "1"],
        }
        frames = len(listed.read_text().split())
        print(f"{frames:,} frames; load {os.getloadavg()[0]:.1f}")
        outputs = {name: timed(command)[2] for name, command in cases.items()}  # warm-up: file cache, numba
        theirs = outputs["official eval_3D_lane.py"].splitlines()[-1].split()  # after its progress lines
        mine = ours_printed(outputs["roneld-eval score openlane3d"]).split()
        print(f"same eight printed numbers: {theirs == mine}" + ("" if theirs == mine else f" ({theirs} / {mine})"))
        interleaved(cases, frames, args.repeats)

if __name__ == "__main__":
    main()
