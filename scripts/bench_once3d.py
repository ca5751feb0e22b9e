"""`score once3d` beside ONCE-3DLanes' own evaluator on the same files, side by side.

Generates a set with `synth --dataset once3d` (--frames of them, 10 a segment), then times,
interleaved so that a change in the machine's load falls on both alike, fresh processes of the
official evaluator (evaluation/eval_utils.py at once-3dlanes/once_3dlanes_benchmark 7582fbb, run as
its eval.py runs it, with its 10 worker processes; by a Python that has its old stack: numpy<1.24,
shapely 1.8, munkres, opencv, prettytable; given by path, never part of this repository) and of
`roneld-eval score once3d --workers 1`. Prints the medians of wall and CPU time (every process's),
their ratios, and whether both printed the same 0.95 row. The target (issue: 3-D lanes) is at least
20x less CPU.

    python scripts/bench_once3d.py --official-python /path/venv/bin/python \\
        --once-benchmark /path/once_3dlanes_benchmark [--frames 1000] [--repeats 5]

The evaluator imports a private `jarvis` package whose wheel is not in its repository: the runner
puts import-only stand-ins (written to a temporary folder) on the path: load_json is json.load, and
the CSV it writes after printing goes to the temporary folder. It leaves its workers' files in
/dev/shm (tmp*0.json .. tmp*9.json), as it always does.
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
from evaluation.eval_utils import LaneEval
LaneEval().lane_evaluation({labels!r}, {preds!r}, {config!r})
"""
STANDINS = {
    "__init__.py": "",
    "eload.py": "import json\n\ndef load_json(path):\n    with open(path) as f:\n        return json.load(f)\n",
    "edump.py": "def ptable_to_csv(table, filename, headers=True):\n"
                "    open(filename, 'w').write(table.get_csv_string())\n",
    "epath.py": "import os\n\ndef inherit(dirname, filename, middlename='', suffix=''):\n"
                "    return os.path.join({out!r}, str(filename) + suffix)\n",
}


def _row(printed: str, threshold: str) -> list[str] | None:
    """The cells after prob_thresh of a threshold's row of a printed table (either tool's)."""
    for line in printed.splitlines():
        cells = [cell.strip() for cell in line.strip().strip("|").split("|")]
        if cells and cells[0].split(" ")[0] == threshold:
            return cells[1:]
    return None


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--official-python", required=True, help="a Python with numpy<1.24, shapely 1.8, munkres, "
                                                                  "opencv and prettytable")
    parser.add_argument("--once-benchmark", required=True, help="once_3dlanes_benchmark's repository (holding "
                                                                 "evaluation/ and cfg/eval.json)")
    parser.add_argument("--frames", type=int, default=1000)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    repo = Path(args.once_benchmark).resolve()
    with tempfile.TemporaryDirectory(prefix="roneld-bench-once3d-") as folder:
        root = Path(folder)
        subprocess.run([sys.executable, "-m", "roneld_eval", "synth", "--dataset", "once3d", "--out",
                        str(root / "set"), "--clips", str(max(1, args.frames // 10)), "--frames", "10"],
                       check=True, capture_output=True)
        labels, preds = root / "set" / "labels", root / "set" / "predictions"
        (root / "standins" / "jarvis").mkdir(parents=True)
        for name, text in STANDINS.items():
            (root / "standins" / "jarvis" / name).write_text(text.replace("{out!r}", repr(str(root))))
        runner = root / "official.py"
        runner.write_text(RUNNER.format(standins=str(root / "standins"), repo=str(repo), labels=str(labels),
                                        preds=str(preds), config=str(repo / "cfg" / "eval.json")))
        cases = {
            "official eval_utils.py": [args.official_python, "-W", "ignore", str(runner)],
            "roneld-eval score once3d": [sys.executable, "-m", "roneld_eval", "score", "once3d", "--labels",
                                         str(labels), "--pred-root", str(preds), "--workers", "1"],
        }
        frames = sum(1 for _ in labels.rglob("*.json"))
        print(f"{frames:,} frames; load {os.getloadavg()[0]:.1f}")
        outputs = {name: timed(command)[2] for name, command in cases.items()}  # warm-up: the file cache, numba
        theirs, mine = (_row(outputs[name], "0.95") for name in cases)
        same = theirs == mine and theirs is not None
        print(f"same 0.95 row: {same}" + ("" if same else f" ({theirs} / {mine})"))
        interleaved(cases, frames, args.repeats)

if __name__ == "__main__":
    main()
