"""Nothing a run reports depends on --workers: results, skips, the error that stops it and the
progress it shows are the same with one worker (in-process) and several (a process pool), and
with none given, where a small run evaluates in fewer workers than cores (pool_size).

The set has clips of each synthetic style (normal, curve, lane change, vanishing ego lanes), a
30-frame one among them, so RONELD's tracking runs through curve mode and lost lanes.
"""

from __future__ import annotations

import multiprocessing
import os
import shutil
import signal
import subprocess
import sys
import threading
from pathlib import Path
from types import FrameType

import numpy as np
import pytest
from conftest import env_importing
from test_run_integrity import wait_for

from roneld_eval import api, evaluation
from roneld_eval import workers as workers_module
from roneld_eval.evaluation import one_clip, pool
from roneld_eval.api import read_dataset
from roneld_eval.resolve import configured
from roneld_eval.errors import InputError
from roneld_eval.benchmarks.culane.synth import synth_culane

OUTPUTS = ("accuracy.csv", "per_frame.csv", "official.csv", "gains.csv")
LENGTHS = [30, 23, 26, 19, 5]


def structure() -> list[tuple[str, list[str]]]:
    clips = [f"driver_1_30frame/clip{k}.MP4" for k in range(len(LENGTHS))]
    return [(clip, [f"{clip}/{30 * i:05d}.jpg" for i in range(n)]) for clip, n in zip(clips, LENGTHS)]


@pytest.fixture(scope="module")
def base(tmp_path_factory):
    root = tmp_path_factory.mktemp("workers-agree") / "set"
    synth_culane(root, structure=structure(), seed=5)
    return root


@pytest.fixture
def dataset(base, tmp_path):
    shutil.copytree(base, tmp_path / "set")
    return tmp_path / "set"


def stem(index: int, clip: int = 0) -> str:
    return structure()[clip][1][index][:-4]


def config_for(root: Path, workers: int, **overrides):
    values = {"dataset.data_root": str(root / "data"), "maps.root": str(root / "maps"), "workers": workers,
              "methods": "baseline,roneld,roneld-nopft", "save_lanes": True}
    values.update(overrides)
    return api.default_config("culane").with_overrides(**values)


def files(folder: Path) -> dict[str, bytes]:
    kept = [path for path in sorted(folder.rglob("*")) if path.is_file()
            and (path.name in OUTPUTS or "lanes" in path.relative_to(folder).parts)]
    return {str(path.relative_to(folder)): path.read_bytes() for path in kept}


def runs(root: Path, tmp_path: Path, counts=(1, 2, 3), **overrides) -> dict[int | None, tuple]:
    out = {}
    for workers in counts:
        folder = tmp_path / f"out{workers}"
        result = api.run(config_for(root, workers, **overrides), folder, progress=False)
        out[workers] = (files(folder), result.counts, result.skipped, list(result.runtime["frames"]))
    return out


def error_of(root: Path, tmp_path: Path, workers: int) -> str:
    with pytest.raises(InputError) as caught:
        api.run(config_for(root, workers), tmp_path / f"out{workers}", progress=False)
    return str(caught.value)


def context_for(root: Path, workers: int) -> evaluation.RunContext:
    config, benchmark = configured(config_for(root, workers, save_lanes=False))
    return evaluation.RunContext(config, benchmark, root / "maps", root / "data", data_root=root / "data")


def clips_of(root: Path):
    return list(read_dataset("culane", root / "data", None, None, labels=False).clips)


def test_workers_change_no_byte(base, tmp_path, monkeypatch):
    monkeypatch.setattr(workers_module, "default_workers", lambda: 4)  # none given: one worker for 103 frames
    found = runs(base, tmp_path, counts=(1, 2, 3, None))
    assert any("lanes" in name for name in found[1][0]) and "per_frame.csv" in found[1][0]
    assert found[1] == found[2] == found[3] == found[None]


def test_pool_size_keeps_what_is_asked_and_sizes_the_default_by_the_frames(base, monkeypatch):
    monkeypatch.setattr(workers_module, "default_workers", lambda: 4)
    clips = clips_of(base)  # 5 clips, 103 frames
    assert [pool.pool_size(asked, clips) for asked in (1, 2, 3, 8)] == [0, 2, 3, 5]
    assert pool.pool_size(None, clips) == 1  # a process of its own: this one prepares the report meanwhile
    assert pool.pool_size(None, clips * 3) == 2  # 309 frames
    assert pool.pool_size(None, clips * 30) == 4  # all the cores
    assert pool.pool_size(2, []) == pool.pool_size(None, []) == 0
    assert pool.pool_size(3, clips[:1]) == pool.pool_size(None, clips[:1]) == 0  # its bar moves frame by frame
    monkeypatch.setattr(workers_module, "default_workers", lambda: 1)
    assert pool.pool_size(None, clips * 30) == 0  # one core: in this process


@pytest.mark.parametrize("asked, workers", [(None, 1), (3, 3), (1, 0)])
def test_meanwhile_runs_once_while_the_workers_warm_up(base, monkeypatch, asked, workers):
    """`run` imports the report's libraries there: the workers exist (forked without them) and
    this process would only wait. Never called in-process, where it would only delay the work."""
    monkeypatch.setattr(workers_module, "default_workers", lambda: 4)
    seen: list[int] = []
    result = api.evaluate(config_for(base, asked, save_lanes=False), progress=False,
                                 meanwhile=lambda: seen.append(len(multiprocessing.active_children())))
    assert result.counts["frames"] == sum(LENGTHS)
    assert seen == ([workers] if workers else [])


def test_the_worker_has_clips_to_evaluate_while_meanwhile_runs(base, monkeypatch, tmp_path):
    """This process hands out no clip while it imports the report's libraries: the worker gets
    twice the clips it would otherwise (two in flight) first, so that it does not wait for them."""
    monkeypatch.setattr(workers_module, "default_workers", lambda: 4)
    evaluate_clip = one_clip.evaluate_clip

    def noted(clip, *args, **kwargs):  # in the worker
        result = evaluate_clip(clip, *args, **kwargs)
        (tmp_path / clip.clip_id.replace("/", "_")).touch()
        return result

    monkeypatch.setattr(one_clip, "evaluate_clip", noted)
    seen: list[int] = []

    def meanwhile():
        wait_for(lambda: len(list(tmp_path.iterdir())) >= 4, 10)
        seen.append(len(list(tmp_path.iterdir())))

    api.evaluate(config_for(base, None, save_lanes=False), progress=False, meanwhile=meanwhile)
    assert seen == [4]  # of the 5 clips, in the one worker the default gives 103 frames


def test_a_signal_while_meanwhile_imports_waits_for_it_to_finish(base, monkeypatch):
    """Seen in an attacker's pass, 1-2% of signals landing in the report's imports: a run hung
    with a module lock taken, aborted, printed a traceback or lost the signal."""
    monkeypatch.setattr(workers_module, "default_workers", lambda: 4)
    steps: list[str] = []

    def meanwhile():
        os.kill(os.getpid(), signal.SIGINT)  # Ctrl-C in the middle of the imports
        for _ in range(1000):  # a Python-level loop, where a signal's handler runs at once
            pass
        steps.append("imports done")

    with pytest.raises(KeyboardInterrupt):
        api.evaluate(config_for(base, None, save_lanes=False), progress=False, meanwhile=meanwhile)
    assert steps == ["imports done"]
    assert wait_for(lambda: not multiprocessing.active_children(), 10)


def test_a_run_forks_its_workers_before_it_imports_pandas_or_matplotlib(tmp_path):
    """Its workers need neither (0.5 s to import): the main process imports them while the
    workers warm up. OpenCV (22 ms) is imported by no process of a run on .npy maps. No timing
    here; scripts/bench_cold.py times the fixture run."""
    program = ("import os, sys\nseen = []\nheavy = ('pandas', 'matplotlib', 'cv2')\n"
               "os.register_at_fork(before=lambda: seen.append([m for m in heavy if m in sys.modules]))\n"
               "from roneld_eval.cli import main\ntry:\n    main(sys.argv[1:])\nexcept SystemExit as e:\n"
               "    assert not e.code, e.code\n    assert 'cv2' not in sys.modules\n"
               "print(len(seen), [m for found in seen for m in found])")
    env = env_importing()
    done = subprocess.run([sys.executable, "-c", program, "run", "--workers", "2", "--quiet", "--out",
                           str(tmp_path / "out")], capture_output=True, text=True, env=env)
    assert done.returncode == 0, done.stderr
    forks, imported = done.stdout.split(maxsplit=1)
    assert int(forks) >= 2 and imported.strip() == "[]", done.stdout
    assert (tmp_path / "out" / "accuracy_curve.png").is_file()


def test_skipped_frames_and_labels_are_listed_alike_for_any_workers(dataset, tmp_path):
    (dataset / "maps" / f"{stem(0)}.npy").write_bytes(b"not a map")  # the clip's first frame
    (dataset / "maps" / f"{stem(9)}.npy").write_bytes(b"not a map")
    (dataset / "data" / f"{stem(10)}.lines.txt").write_text("1 2 three\n")
    (dataset / "data" / f"{stem(21)}.lines.txt").write_text("1 2 three\n")
    found = runs(dataset, tmp_path, on_error="skip")
    assert found[1] == found[2] == found[3]
    assert [entry.split(": ")[0].rsplit("/", 1)[-1] for entry in found[1][2]] == [
        "00300.lines.txt:1", "00630.lines.txt:1", "00000.npy", "00270.npy"]


def test_the_same_error_for_any_workers_when_two_clips_are_bad(dataset, tmp_path):
    (dataset / "maps" / f"{stem(9, clip=1)}.npy").write_bytes(b"not a map")
    (dataset / "data" / f"{stem(21, clip=2)}.lines.txt").write_text("1 2 three\n")
    messages = {workers: error_of(dataset, tmp_path, workers) for workers in (1, 2, 3)}
    assert messages[1] == messages[2] == messages[3], messages
    assert str(dataset / "maps" / f"{stem(9, clip=1)}.npy") in messages[1]


def test_a_size_change_within_a_clip_names_its_file(dataset, tmp_path):
    path = dataset / "maps" / f"{stem(17)}.npy"
    np.save(path, np.load(path)[:, ::2, ::2].copy())
    for workers in (1, 2):
        message = error_of(dataset, tmp_path, workers)
        assert message.startswith(f"{path}: maps of shape") and "differ from the clip's first frame" in message


def test_progress_counts_every_frame_once(base):
    for workers in (1, 2):
        told: list[int] = []
        results = list(evaluation._clip_results(clips_of(base), context_for(base, workers), workers,
                                                advance=told.append))
        assert [result.clip_id for result in results] == [clip.clip_id for clip in clips_of(base)]
        assert sum(told) == sum(LENGTHS), workers
        if workers == 1:  # in-process, the bar moves within a clip
            assert len(told) == sum(LENGTHS)


def test_one_clip_is_evaluated_in_process_its_bar_moving_frame_by_frame(base, monkeypatch):
    """A long video as one clip must not show a bar that stands still until its end."""
    monkeypatch.setattr(workers_module, "default_workers", lambda: 4)
    for workers in (None, 3):
        told: list[int] = []
        list(evaluation._clip_results(clips_of(base)[:1], context_for(base, workers), workers, advance=told.append))
        assert told == [1] * LENGTHS[0], workers


class _InterruptedLock:
    """A Condition's waiter lock whose blocking acquire is cut by Ctrl-C (the first press)."""

    def __init__(self, real):
        self.real = real
        self.calls = 0

    def acquire(self, *args, **kwargs):
        self.calls += 1
        if self.calls == 2 and _Trap.armed:
            _Trap.armed = False
            _Trap.second = True
            raise KeyboardInterrupt
        return self.real.acquire(*args, **kwargs)

    def release(self):
        return self.real.release()

    def locked(self):
        return self.real.locked()

    __enter__ = acquire

    def __exit__(self, *exc):
        self.real.release()


def _starting_a_thread() -> bool:
    """Whether the caller is Thread.start (the pool starting its own threads on a first submit):
    a window far narrower than the main process's waits for results, left out of the trap."""
    frame: FrameType | None = sys._getframe(1)
    while frame is not None:
        if frame.f_code.co_name == "start" and frame.f_code.co_filename == threading.__file__:
            return True
        frame = frame.f_back
    return False


class _Trap:
    armed = False
    second = False


def test_ctrl_c_twice_while_waiting_is_an_interruption(base, monkeypatch):
    """Deterministic form of pressing Ctrl-C twice: the first press cuts a Condition.wait of the
    main thread, the second lands as that wait re-takes its lock (seen as a real race: 5 of 18
    double SIGINTs gave the RuntimeError, one hung). A Ctrl-C must stay a KeyboardInterrupt."""
    main, pid = threading.main_thread(), os.getpid()

    def in_main() -> bool:  # the main process's main thread (forked workers inherit the trap)
        return os.getpid() == pid and threading.current_thread() is main

    allocate = threading._allocate_lock  # type: ignore[attr-defined]
    restore = threading.Condition._acquire_restore  # type: ignore[attr-defined]

    def allocate_lock():
        lock = allocate()
        waiting = in_main() and _Trap.armed and not _starting_a_thread()
        return _InterruptedLock(lock) if waiting else lock

    def acquire_restore(self, state):
        if _Trap.second and in_main():
            _Trap.second = False
            raise KeyboardInterrupt  # the second press, before the lock is taken back
        return restore(self, state)

    monkeypatch.setattr(threading, "_allocate_lock", allocate_lock)
    monkeypatch.setattr(threading.Condition, "_acquire_restore", acquire_restore)
    clips, context = clips_of(base), context_for(base, 2)
    results = evaluation._clip_results(clips, context, 2)
    _Trap.armed, _Trap.second = True, False
    try:
        with pytest.raises(KeyboardInterrupt):
            list(results)
            raise KeyboardInterrupt  # not trapped at all: no Python-level wait in the main thread
    finally:
        _Trap.armed = _Trap.second = False
