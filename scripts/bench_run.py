"""Benchmark `roneld-eval run`: frames per second with baseline and RONELD, 1 worker and all.

Generates a CULane-shaped set of at least --frames frames (4x288x800 uint8 .npy maps), with
the videos and frame numbering of the official CULane test list when
../shared/data/culane-lists/test.txt is present (whole videos, in list order), then runs the
full evaluation (paper protocol, official CULane scores, all outputs) with one worker and with
every core, and prints frames per second and peak memory. Memory should not grow with frames:
the run is repeated on half the set to show it.

With --against REV (default cdebfc1, the tool when issue 15 was filed) it instead times the
whole command of that revision (a temporary `git worktree` outside the repository, run with the
same Python and PYTHONPATH pointing at it, its numba cache in a temporary folder) against this
checkout's, alternating on the same set, each warmed up first: frames/s of both, their ratio,
whether per_frame.csv, official.csv and accuracy.csv are byte-identical, the peak RSS of the
main process and of the largest child process (a worker, or the figure process) of each, and
the CPU seconds of all their processes (less sensitive than wall time to other work on the
machine). Every map is read once first, so that
both read from the page cache. The worktree is removed at the end, also on Ctrl-C or SIGTERM.

With --memory it instead measures how the peak memory of the main process (and of the largest
child) grows with the number of frames: the set is written as lane files (`--maps-format lanes`:
the main process holds the same per frame whatever the maps, and 34,680 frames take 0.4 GB
instead of 32 GB of .npy), and the whole command runs on its first eighth, half and all of its
videos, twice each (--repeats); it prints each peak and the growth per 1,000 frames (least
squares; only over 10,000 frames or more, as peaks vary by ~0.5 MB between identical runs). With
--against REV too, the same for that revision.

With --compare-scoring it instead times, in one go on the same set, the whole command with
scoring as it was before masks became runs per row (roneld_eval.metrics.reference: every lane
drawn pixel by pixel on a canvas) against the current scoring, alternating, and one official
CULane lane mask both ways (ms per ground-truth lane of the set, one core).

    python scripts/bench_run.py [--frames 2000] [--data DIR] [--against [REV] | --compare-scoring]
    python scripts/bench_run.py --memory [--frames 34680] [--data DIR] [--against [REV]]
"""

from __future__ import annotations

import argparse
import collections
import contextlib
import filecmp
import os
import posixpath
import shutil
import signal
import subprocess
import sys
import tempfile
import textwrap
import time
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Iterator

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from roneld_eval.evaluation import default_workers  # noqa: E402
from roneld_eval.benchmarks.culane.synth import synth_culane  # noqa: E402

TEST_LIST = REPO.parent / "shared" / "data" / "culane-lists" / "test.txt"


def structure(frames: int):
    """(video, frame relpaths) of whole videos from the real test list until `frames` are reached."""
    if not TEST_LIST.is_file():
        return None
    videos: dict[str, list[str]] = {}
    for line in TEST_LIST.read_text().split():
        relpath = line.lstrip("/")
        videos.setdefault(posixpath.dirname(relpath), []).append(relpath)
    chosen, total = [], 0
    for video, relpaths in videos.items():
        chosen.append((video, relpaths))
        total += len(relpaths)
        if total >= frames:
            break
    return chosen


# `python -m roneld_eval` (or `_REFERENCE`: with scoring's masks drawn on canvases, as before
# runs per row), then the peak RSS of this (main) process and of its largest reaped child (a
# worker, or the process drawing a figure: forked from the main one late, it shares the main
# one's pages and counts them again), and the CPU seconds of both, written as
# "main_kb child_kb cpu_s" to the file named by $RONELD_BENCH_PEAK.
_RUN = "runpy.run_module('roneld_eval', run_name='__main__', alter_sys=True)"
_REFERENCE = "from roneld_eval.metrics.reference import drawn_masks\nwith drawn_masks():\n    " + _RUN


def _measured(body: str) -> str:
    return ("import os, resource, runpy\ntry:\n" + textwrap.indent(body, "    ") + "\nfinally:\n"
            "    own = resource.getrusage(resource.RUSAGE_SELF)\n"
            "    children = resource.getrusage(resource.RUSAGE_CHILDREN)\n"
            "    cpu = own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime\n"
            "    with open(os.environ['RONELD_BENCH_PEAK'], 'w') as peak:\n"
            "        peak.write(f'{own.ru_maxrss} {children.ru_maxrss} {cpu}')\n")


@dataclass(frozen=True)
class Timed:
    """One whole command: wall seconds, peak RSS (MB) of the main process and of its largest child,
    and CPU seconds of all its processes."""

    seconds: float
    main_mb: float
    worker_mb: float
    cpu_s: float = 0.0


def timed_run(data: Path, maps: Path, workers: int, limit: int | None, out: Path,
              reference_scoring: bool = False, tree: Path = REPO, env: dict[str, str] | None = None,
              maps_format: str = "npy") -> Timed:
    """Run `roneld-eval run` of the code in `tree` (started there, PYTHONPATH=tree) on the set."""
    code = _measured(_REFERENCE if reference_scoring else _RUN)
    command = [sys.executable, "-c", code, "run", "--dataset", "culane", "--data-root", str(data),
               "--maps-root", str(maps), "--maps-format", maps_format, "--methods", "baseline,roneld",
               "--workers", str(workers), "--out", str(out), "--quiet"]
    if limit:
        command += ["--limit", str(limit)]
    environment = dict(os.environ if env is None else env)
    # The tree first on sys.path (python -c puts its working directory, the tree, first too),
    # ahead of the editable install's finder, which would otherwise import this checkout.
    environment["PYTHONPATH"] = str(tree)
    with tempfile.NamedTemporaryFile(prefix="roneld-bench-peak-") as peak:
        environment["RONELD_BENCH_PEAK"] = peak.name
        start = time.perf_counter()
        _run_group(command, cwd=tree, env=environment)
        elapsed = time.perf_counter() - start
        main_kb, worker_kb, cpu_s = (Path(peak.name).read_text().split() or ["0", "0", "0"])
    return Timed(elapsed, int(main_kb) / 1024, int(worker_kb) / 1024, float(cpu_s))


def _run_group(command: list[str], **options) -> None:
    """Run a command in a process group of its own; if this one is interrupted (Ctrl-C, SIGTERM),
    end the whole group (workers and kernel compilers included) before going on."""
    process = subprocess.Popen(command, start_new_session=True, **options)
    try:
        code = process.wait()
    except BaseException:
        for sent in (signal.SIGTERM, signal.SIGKILL):
            try:
                os.killpg(process.pid, sent)
                process.wait(timeout=10)
                break
            except (ProcessLookupError, subprocess.TimeoutExpired):
                continue
        raise
    if code != 0:
        raise subprocess.CalledProcessError(code, command)


def evaluation_seconds(out: Path) -> float:
    """The run's own wall time (summary.json): evaluation and report, without Python start-up."""
    import json

    return json.loads((out / "summary.json").read_text())["wall_time_s"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, help="frames to generate (default 2000; with --memory 34,680, the "
                        "whole CULane test list)")
    parser.add_argument("--data", type=Path, help="where to generate the set (default: a temporary folder)")
    parser.add_argument("--repeats", type=int, help="timed runs of each kind (the median is printed; default 3, "
                        "with --memory 2 per size)")
    choice = parser.add_mutually_exclusive_group()
    choice.add_argument("--against", metavar="REV", nargs="?", const=OLD_REVISION,
                        help=f"time the whole command of git revision REV (default {OLD_REVISION}) against this "
                             "checkout's, alternating, on the same set")
    choice.add_argument("--compare-scoring", action="store_true",
                        help="time the run with canvas-drawn masks (the old scoring) against the current one")
    parser.add_argument("--memory", action="store_true",
                        help="peak memory against the number of frames (on lane files; with --against, of both)")
    args = parser.parse_args()
    if args.memory and args.compare_scoring:
        parser.error("--memory measures memory alone: no --compare-scoring with it")
    if args.frames is None:
        args.frames = 34680 if args.memory else 2000
    if args.repeats is None:
        args.repeats = 2 if args.memory else 3
    if args.against and subprocess.run(["git", "-C", str(REPO), "rev-parse", "--verify", "--quiet",
                                        f"{args.against}^{{commit}}"], capture_output=True).returncode != 0:
        sys.exit(f"--against {args.against}: no such revision in {REPO}")
    folder = (args.data or Path(tempfile.mkdtemp(prefix="roneld-bench-run-"))).resolve()
    layout = structure(args.frames)
    start = time.perf_counter()
    maps_format = "lanes" if args.memory else "npy"
    if not (folder / "data" / "list" / "test.txt").exists():
        result = synth_culane(folder, clips=max(args.frames // 30, 1), frames=30, structure=layout, seed=1,
                              maps_format=maps_format)
        print(f"generated {result.n_frames} frames in {result.n_clips} videos "
              f"({'CULane test list layout' if layout else 'synthetic layout'}) in {time.perf_counter() - start:.0f} s")
    data, maps = folder / "data", folder / "maps"
    frames = len((data / "list" / "test.txt").read_text().split())
    videos = len({posixpath.dirname(line) for line in (data / "list" / "test.txt").read_text().split()})
    found = ("lanes" if next(maps.rglob("*.lines.txt"), None) is not None
             else "npy" if next(maps.rglob("*.npy"), None) is not None else None)
    if found != maps_format:
        sys.exit(f"{folder} holds {f'{found} maps' if found else 'no maps'}; --memory needs a set of lane files, "
                 "the other modes one of .npy maps")
    print(f"{frames} frames in {videos} videos, "
          f"{'CULane lane files' if args.memory else '4x288x800 uint8 .npy'}; methods baseline, roneld; "
          f"{os.cpu_count()} cores; {load()}")
    if args.memory:
        memory(data, maps, folder, args.against, args.repeats)
        return
    if args.against:
        against(args.against, data, maps, folder, frames, args.repeats)
        return
    # Warm the page cache and numba's on-disk cache so both runs read the same way.
    timed_run(data, maps, 1, 1, folder / "warm")
    if args.compare_scoring:
        compare_scoring(data, maps, folder, frames, args.repeats)
        return
    for workers in sorted({1, default_workers()}):
        runs = [timed_run(data, maps, workers, None, folder / f"out-{workers}") for _ in range(args.repeats)]
        run = median(runs)
        inner = evaluation_seconds(folder / f"out-{workers}")
        print(f"  {workers} worker(s): {run.seconds:6.1f} s  {frames / run.seconds:6.0f} frames/s for the whole "
              f"command, median of {args.repeats} ({inner:.1f} s inside the run: {frames / inner:.0f} frames/s; "
              f"{peaks(run)})")
    half = max(videos // 2, 1)
    run = timed_run(data, maps, default_workers(), half, folder / "out-half")
    print(f"  first {half} videos only, all workers: {run.seconds:6.1f} s  ({peaks(run)})")
    print("Target: at least 400 frames/s on 2 cores (the 34,680-frame CULane test set in under 1.5 minutes).")
    print(f"  ({load()})")


def median(runs: list[Timed]) -> Timed:
    """The run of median wall time."""
    return sorted(runs, key=lambda run: run.seconds)[len(runs) // 2]


def peaks(run: Timed) -> str:
    return f"peak RSS: main process {run.main_mb:.0f} MB, largest child {run.worker_mb:.0f} MB"


def load() -> str:
    """The machine's load averages (1, 5, 15 minutes), as `uptime` prints them."""
    return "load average " + ", ".join(f"{value:.2f}" for value in os.getloadavg())


OUTPUTS = ("per_frame.csv", "official.csv", "accuracy.csv")  # the numbers; must be the same bytes
OLD_REVISION = "cdebfc1"  # the tool when issue 15 (speed of real maps) was filed


@contextmanager
def worktree(revision: str) -> Iterator[Path]:
    """A detached checkout of `revision` in a temporary folder outside the repository, removed
    (with git's record of it) when the block ends, by an exception, Ctrl-C or SIGTERM included."""
    parent = Path(tempfile.mkdtemp(prefix="roneld-bench-against-"))
    tree = parent / "tree"
    previous = signal.signal(signal.SIGTERM, _interrupt)
    try:
        subprocess.run(["git", "-C", str(REPO), "worktree", "add", "--detach", "--quiet", str(tree), revision],
                       check=True)
        yield tree
    finally:
        # Held off here: a second Ctrl-C must not leave the worktree behind.
        held = signal.signal(signal.SIGINT, signal.SIG_IGN)
        try:
            subprocess.run(["git", "-C", str(REPO), "worktree", "remove", "--force", str(tree)],
                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            shutil.rmtree(parent, ignore_errors=True)
            subprocess.run(["git", "-C", str(REPO), "worktree", "prune"], stdout=subprocess.DEVNULL,
                           stderr=subprocess.DEVNULL)
        finally:
            signal.signal(signal.SIGINT, held)
            signal.signal(signal.SIGTERM, previous)


def _interrupt(signum, frame) -> None:
    raise KeyboardInterrupt


def read_all(folder: Path) -> int:
    """Read every file under `folder` once (into the page cache); the bytes read."""
    total = 0
    for path in sorted(folder.rglob("*")):
        if path.is_file():
            with path.open("rb") as stream:
                while chunk := stream.read(1 << 22):
                    total += len(chunk)
    return total


@contextmanager
def compared_trees(revision: str | None) -> Iterator[dict[str, tuple[Path, dict[str, str]]]]:
    """{"old": (worktree of `revision`, its environment), "new": (this checkout, ...)}, "new"
    alone without a revision; each checked to import its own code, not the editable install's."""
    with contextlib.ExitStack() as stack:
        trees = {"new": (REPO, dict(os.environ))}
        if revision:
            old_tree = stack.enter_context(worktree(revision))
            # The old code compiles into its own numba cache, removed with it: numba keys entries by
            # source path, so it would not mix with ours, but it would leave dead entries behind.
            numba_dir = stack.enter_context(tempfile.TemporaryDirectory(prefix="roneld-bench-numba-"))
            trees = {"old": (old_tree, dict(os.environ, NUMBA_CACHE_DIR=numba_dir)), **trees}
        for name, (tree, env) in trees.items():
            imported = subprocess.run([sys.executable, "-c", "import roneld_eval; print(roneld_eval.__file__)"],
                                      cwd=tree, env=dict(env, PYTHONPATH=str(tree)), check=True,
                                      capture_output=True, text=True).stdout.strip()
            if not Path(imported).resolve().is_relative_to(tree.resolve()):
                sys.exit(f"the {name} run would import {imported}, not the code in {tree}")
        yield trees


def against(revision: str, data: Path, maps: Path, folder: Path, frames: int, repeats: int = 3) -> None:
    """The whole command of `revision` against this checkout's, alternating on the same set."""
    workers = default_workers()
    described = subprocess.run(["git", "-C", str(REPO), "log", "-1", "--format=%h %s", revision], check=True,
                               capture_output=True, text=True).stdout.strip()
    with compared_trees(revision) as trees:
        old_tree = trees["old"][0]
        print(f"  old: {described} (worktree {old_tree}); new: this checkout {REPO}")
        start = time.perf_counter()
        size = read_all(maps)
        print(f"  read every map once ({size / 2**30:.1f} GiB, {time.perf_counter() - start:.0f} s): both read from "
              "the page cache")
        # Warm-up: numba's cache of each (the old one compiles from nothing).
        for name, (tree, env) in trees.items():
            start = time.perf_counter()
            timed_run(data, maps, workers, 1, folder / f"warm-{name}", tree=tree, env=env)
            print(f"  warm-up {name}: {time.perf_counter() - start:.0f} s")
        runs: dict[str, list[Timed]] = {"old": [], "new": []}
        for repeat in range(repeats):
            # Alternating, and which goes first too: neither always runs after the other.
            for name in ("old", "new") if repeat % 2 == 0 else ("new", "old"):
                tree, env = trees[name]
                runs[name].append(timed_run(data, maps, workers, None, folder / f"out-{name}", tree=tree, env=env))
                print(f"    {name}: {runs[name][-1].seconds:6.1f} s, {runs[name][-1].cpu_s:5.1f} CPU s ({load()})",
                      flush=True)
    old, new = median(runs["old"]), median(runs["new"])
    differ = [name for name in OUTPUTS
              if not filecmp.cmp(folder / "out-old" / name, folder / "out-new" / name, shallow=False)]
    print(f"  {workers} worker(s), whole `roneld-eval run`, median of {repeats} (alternating), {load()}:")
    cpu = {name: sorted(run.cpu_s for run in timed)[len(timed) // 2] for name, timed in runs.items()}
    print(f"    old ({revision}): {old.seconds:6.1f} s  {frames / old.seconds:6.0f} frames/s  ({peaks(old)})")
    print(f"    new (checkout): {new.seconds:6.1f} s  {frames / new.seconds:6.0f} frames/s  ({peaks(new)})")
    print(f"    new / old frames/s = {old.seconds / new.seconds:.2f}x (target 1.5x); CPU seconds, median: old "
          f"{cpu['old']:.1f}, new {cpu['new']:.1f} ({cpu['old'] / cpu['new']:.2f}x); "
          + (f"{', '.join(OUTPUTS)} byte-identical" if not differ else f"DIFFERENT: {', '.join(differ)}"))


# Peak RSS moves by about half a megabyte between identical runs: a growth figure needs
# at least this many frames between the smallest and the largest run to mean anything.
MEMORY_SPAN = 10000


def memory(data: Path, maps: Path, folder: Path, revision: str | None, repeats: int = 2) -> None:
    """Peak RSS of the main process and largest child on the first 1/8, 1/2 and all videos."""
    listed = (data / "list" / "test.txt").read_text().split()
    videos = list(dict.fromkeys(posixpath.dirname(line) for line in listed))
    workers = default_workers()
    # At least a video per worker: a run with one task evaluates in the main process, which then
    # holds the extractors' and scoring's compiled code too (some 90 MB more at any size).
    sizes = sorted({min(max(len(videos) // part, workers), len(videos)) for part in (8, 2, 1)})
    per_video = collections.Counter(posixpath.dirname(line) for line in listed)
    frames_of = {size: sum(per_video[video] for video in videos[:size]) for size in sizes}
    with compared_trees(revision) as trees:
        for which, (tree, env) in trees.items():
            name = f"old ({revision})" if which == "old" else "new (checkout)"
            try:
                timed_run(data, maps, workers, 1, folder / "warm", tree=tree, env=env, maps_format="lanes")
            except subprocess.CalledProcessError:
                print(f"  {name}: its run failed on the lane files (before --maps-format lanes?); left out")
                continue
            print(f"  {name}, {workers} worker(s), peak RSS (MB) of the main process / largest child, "
                  f"{repeats} runs each:")
            peaks_of: dict[int, list[float]] = {}
            for size in sizes:
                runs = [timed_run(data, maps, workers, size, folder / "out-memory", tree=tree, env=env,
                                  maps_format="lanes") for _ in range(repeats)]
                peaks_of[size] = [run.main_mb for run in runs]
                print(f"    {size:4d} videos, {frames_of[size]:6d} frames: main "
                      f"{', '.join(f'{run.main_mb:.1f}' for run in runs)}; largest child "
                      f"{', '.join(f'{run.worker_mb:.1f}' for run in runs)}  ({load()})", flush=True)
            xs = [frames_of[size] for size in sizes for _ in peaks_of[size]]
            ys = [peak for size in sizes for peak in peaks_of[size]]
            if max(xs) - min(xs) < MEMORY_SPAN:
                print(f"    no growth figure: {min(xs)} to {max(xs)} frames is too short a span (peaks vary by "
                      f"~0.5 MB between identical runs; use at least {MEMORY_SPAN:,} frames, e.g. the default)")
                continue
            slope = float(np.polyfit(np.array(xs, np.float64), np.array(ys, np.float64), 1)[0])  # MB a frame
            print(f"    main process: {slope * 1024 * 1000:.0f} KB per 1,000 frames between {min(xs):,} and "
                  f"{max(xs):,} frames, {slope * 34680:.1f} MB over the 34,680-frame CULane test set "
                  "(least squares over the runs above)")


def compare_scoring(data: Path, maps: Path, folder: Path, frames: int, repeats: int = 3) -> None:
    """Old (canvas) against new (runs) scoring: whole runs alternating, then one lane mask."""
    workers = default_workers()
    timed_run(data, maps, workers, 1, folder / "warm-old", reference_scoring=True)
    seconds: dict[bool, list[float]] = {True: [], False: []}
    for _ in range(repeats):
        for reference in (True, False):
            out = folder / f"out-{'old' if reference else 'new'}"
            seconds[reference].append(timed_run(data, maps, workers, None, out, reference).seconds)
    old, new = sorted(seconds[True])[repeats // 2], sorted(seconds[False])[repeats // 2]
    same = all(filecmp.cmp(folder / "out-old" / name, folder / "out-new" / name, shallow=False)
               for name in OUTPUTS)
    print(f"  {workers} worker(s), whole command, median of {repeats} (alternating), {load()}:")
    print(f"    old scoring (canvas masks): {old:6.1f} s  {frames / old:6.0f} frames/s")
    print(f"    new scoring (runs per row): {new:6.1f} s  {frames / new:6.0f} frames/s  = {old / new:.2f}x "
          f"({'identical' if same else 'DIFFERENT'} per_frame.csv, official.csv, accuracy.csv)")
    lane_mask_ms(data)


def lane_mask_ms(data: Path, lanes_wanted: int = 4000) -> None:
    """ms per official lane mask (1640x590, 30 px) on the set's ground-truth lanes, both ways."""
    from roneld_eval import kernels
    from roneld_eval.lanes_io import read_lines_txt
    from roneld_eval.metrics.raster import official_mask, official_mask_by_canvas

    kernels.warm_up(["official"])
    lanes = []
    for path in sorted(data.rglob("*.lines.txt")):
        lanes += [lane for lane in read_lines_txt(path) if len(lane) >= 2]
        if len(lanes) >= lanes_wanted:
            break
    for name, draw in (("canvas (old)", official_mask_by_canvas), ("runs per row (new)", official_mask)):
        draw(lanes[0], 1640, 590, 30)  # one lane at a time is not what a run compiles ahead: compile it here
        runs = []
        for _ in range(5):
            start = time.process_time()
            for lane in lanes:
                draw(lane, 1640, 590, 30)
            runs.append(time.process_time() - start)
        print(f"  official lane mask, {name:18s}: {1e3 * min(runs) / len(lanes):.3f} ms per lane "
              f"(CPU, best of 5, {len(lanes)} ground-truth lanes)")


if __name__ == "__main__":
    try:
        main()
    except KeyboardInterrupt:  # Ctrl-C or SIGTERM: the worktree is already removed
        print("interrupted", file=sys.stderr)
        sys.exit(130)
