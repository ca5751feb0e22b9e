"""`score apollo3d` beside Gen-LaneNet's own evaluator on the same files, side by side.

Generates a set with `synth --dataset apollo3d` (--frames of them), then times, interleaved so that
a change in the machine's load falls on both alike, fresh processes of the official evaluator
(tools/eval_3D_lane.py at yuliangguo/Pytorch_Generalized_3D_Lane_Detection 45c6cc4, its `__main__`:
the 19-threshold sweep, then the chosen threshold; run by a Python that has its old stack:
numpy<1.24, scipy, ortools 9.3, ujson, opencv, matplotlib; given by path, never part of this
repository) and of `roneld-eval score apollo3d --workers 1`. Prints the medians of wall and CPU
time, their ratios, and whether both printed the same lines. The target (issue: 3-D lanes) is at
least 20x less CPU.

    python scripts/bench_apollo3d.py --official-python /path/venv/bin/python \\
        --gen-lanenet /path/Pytorch_Generalized_3D_Lane_Detection [--frames 1000] [--repeats 5]

tools/utils.py imports torch, which the evaluation never calls: the runner puts an import-only
stand-in (empty modules written to a temporary folder) before it on the path.
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
sys.path[:0] = [{standins!r}, {repo!r}]
from tools import eval_3D_lane as official
from tools.utils import define_args, sim3d_config
args = define_args().parse_args([])
sim3d_config(args)
evaluator = official.LaneEval(args)
pr = evaluator.bench_one_submit_varying_probs({pred!r}, {labels!r})
stats = evaluator.bench_one_submit({pred!r}, {labels!r}, prob_th=pr['max_F_prob_th'], vis=False)
line = "{{}}:  {{:.3}}  {{:.3}}  {{:.3}}  {{:.3}}  {{:.3}}  {{:.3}}"
print(line.format("Laneline", pr['laneline_AP'], stats[0], *stats[3:7]))
print(line.format("Centerline", pr['centerline_AP'], stats[7], *stats[10:14]))
"""
TORCH = ("__init__.py", "nn/__init__.py", "nn/init.py", "optim/__init__.py", "optim/lr_scheduler.py")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--official-python", required=True, help="a Python with numpy<1.24, scipy, ortools 9.3, "
                                                                  "ujson, opencv and matplotlib")
    parser.add_argument("--gen-lanenet", required=True, help="Gen-LaneNet's repository (the folder holding tools/)")
    parser.add_argument("--frames", type=int, default=1000)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="roneld-bench-apollo3d-") as folder:
        root = Path(folder)
        subprocess.run([sys.executable, "-m", "roneld_eval", "synth", "--dataset", "apollo3d", "--out",
                        str(root / "set"), "--clips", str(max(1, args.frames // 10)), "--frames", "10"],
                       check=True, capture_output=True)
        labels, pred = root / "set" / "test.json", root / "set" / "pred.json"
        for name in TORCH:
            (root / "standins" / "torch" / name).parent.mkdir(parents=True, exist_ok=True)
            (root / "standins" / "torch" / name).write_text("")
        runner = root / "official.py"
        runner.write_text(RUNNER.format(standins=str(root / "standins"), repo=str(Path(args.gen_lanenet).resolve()),
                                        pred=str(pred), labels=str(labels)))
        cases = {
            "official eval_3D_lane.py": [args.official_python, "-W", "ignore", str(runner)],
            "roneld-eval score apollo3d": [sys.executable, "-m", "roneld_eval", "score", "apollo3d", "--labels",
                                           str(labels), "--pred", str(pred), "--workers", "1"],
        }
        frames = len(labels.read_text().splitlines())
        print(f"{frames:,} frames; load {os.getloadavg()[0]:.1f}")
        outputs = {name: timed(command)[2] for name, command in cases.items()}  # warm-up: the file cache
        theirs = [line for line in outputs["official eval_3D_lane.py"].splitlines() if "line:" in line]
        mine = [line.strip() for line in outputs["roneld-eval score apollo3d"].splitlines() if "line:" in line]
        print(f"same printed lines: {theirs == mine}" + ("" if theirs == mine else f" ({theirs} / {mine})"))
        interleaved(cases, frames, args.repeats)

if __name__ == "__main__":
    main()
