"""Timing an official evaluator and roneld-eval side by side, as the 3-D lane benchmarks'
scripts do (bench_openlane3d.py, bench_apollo3d.py, bench_once3d.py): fresh processes, interleaved
so that a change in the machine's load falls on both alike, medians of wall and CPU time."""

from __future__ import annotations

import os
import resource
import statistics
import subprocess
import time


def timed(command: list[str]) -> tuple[float, float, str]:
    """(wall s, CPU s of the child and every process it waited for, its stdout)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    done = subprocess.run(command, check=True, capture_output=True, text=True)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), done.stdout


def interleaved(cases: dict[str, list[str]], frames: int, repeats: int) -> None:
    """Run the two `cases` (the official first) `repeats` times in turn; print each one's medians
    and ours against the official's."""
    walls: dict[str, list[float]] = {name: [] for name in cases}
    cpus: dict[str, list[float]] = {name: [] for name in cases}
    for _ in range(repeats):
        for name, command in cases.items():
            wall, cpu, _ = timed(command)
            walls[name].append(wall)
            cpus[name].append(cpu)
    for name in cases:
        wall, cpu = statistics.median(walls[name]), statistics.median(cpus[name])
        print(f"  {name:32s} wall {wall:7.2f} s  CPU {cpu:7.2f} s  ({1000 * cpu / frames:.2f} ms CPU a frame)")
    official, ours = cases
    print(f"ours / official: wall {statistics.median(walls[ours]) / statistics.median(walls[official]):.3f}x, "
          f"CPU {statistics.median(cpus[ours]) / statistics.median(cpus[official]):.3f}x "
          f"(official / ours: {statistics.median(cpus[official]) / statistics.median(cpus[ours]):.1f}x); "
          f"load {os.getloadavg()[0]:.1f}")
