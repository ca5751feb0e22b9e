"""Attacks on long clips cut into segments (a4491c2, 961861c): what --workers must not change.

Four tests reproduce bugs that attack pass found (and that are fixed): an error or the progress
bar that depended on --workers, a long clip's predictions kept in the main process, and Ctrl-C
twice while the main process waited on the workers (a traceback, or a hang).
Segments are lowered to a few frames, as in test_long_clips.py, so a set runs in seconds.
"""

from __future__ import annotations

import os
import shutil
import sys
import threading
from pathlib import Path
from types import FrameType

import numpy as np
import pytest

from roneld_eval import api, evaluation
from roneld_eval.datasets import read_dataset
from roneld_eval.errors import InputError
from roneld_eval.synth import synth_culane

SEGMENT = 4
CLIP = "driver_1_30frame/long.MP4"
LENGTH = 30  # segments of 4: frames 8..11 are the third segment, 20..23 the sixth
OUTPUTS = ("accuracy.csv", "per_frame.csv", "official.csv", "gains.csv")


def structure() -> list[tuple[str, list[str]]]:
    short = "driver_9_30frame/short.MP4"
    return [(CLIP, [f"{CLIP}/{30 * i:05d}.jpg" for i in range(LENGTH)]),
            (short, [f"{short}/{30 * i:05d}.jpg" for i in range(5)])]


@pytest.fixture(scope="module")
def base(tmp_path_factory):
    root = tmp_path_factory.mktemp("long-clip-attacks") / "set"
    synth_culane(root, structure=structure(), seed=7)
    return root


@pytest.fixture
def dataset(base, tmp_path):
    shutil.copytree(base, tmp_path / "set")
    return tmp_path / "set"


@pytest.fixture(autouse=True)
def short_segments(monkeypatch):
    monkeypatch.setattr(evaluation, "SEGMENT_FRAMES", SEGMENT)


def stem(index: int) -> str:
    return f"{CLIP}/{30 * index:05d}"


def config_for(root: Path, workers: int, **overrides):
    values = {"dataset.data_root": str(root / "data"), "maps.root": str(root / "maps"), "workers": workers,
              "methods": "baseline,roneld,roneld-nopft"}
    values.update(overrides)
    return api.default_config("culane").with_overrides(**values)


def error_of(root: Path, tmp_path: Path, workers: int) -> str:
    with pytest.raises(InputError) as caught:
        api.run(config_for(root, workers), tmp_path / f"out{workers}", progress=False)
    return str(caught.value)


def context_for(root: Path, workers: int) -> evaluation.RunContext:
    config = config_for(root, workers)
    return evaluation.RunContext(config, root / "maps", root / "data", data_root=root / "data")


def clips_of(root: Path):
    return list(read_dataset("culane", root / "data", None, None, labels=False).clips)


def test_the_same_error_for_any_workers_when_two_segments_are_bad(dataset, tmp_path):
    (dataset / "maps" / f"{stem(9)}.npy").write_bytes(b"not a map")  # third segment
    (dataset / "data" / f"{stem(21)}.lines.txt").write_text("1 2 three\n")  # sixth segment
    messages = {workers: error_of(dataset, tmp_path, workers) for workers in (1, 2, 3)}
    assert messages[1] == messages[2] == messages[3], messages


def test_progress_moves_within_a_long_clip_with_one_worker(base):
    told: list[int] = []
    context = context_for(base, 1)
    list(evaluation._clip_results(clips_of(base), context, 1, advance=told.append))
    assert len(told) == len(evaluation.segments_of(clips_of(base)[0], context)) + 1 and sum(told) == LENGTH + 5


def test_the_main_process_keeps_no_predictions_of_a_long_clip(base, monkeypatch):
    kept = []
    merged = evaluation.merged_clip

    def recording(clip, extractions, scored):
        kept.extend(extractions)
        return merged(clip, extractions, scored)

    monkeypatch.setattr(evaluation, "merged_clip", recording)
    results = list(evaluation._clip_results(clips_of(base), context_for(base, 2), 2))
    assert results[0].n_scored == LENGTH and results[0].n_gt_lanes > 0
    assert len(kept) == len(evaluation.segments_of(clips_of(base)[0], context_for(base, 2)))
    assert all(not part.labelled for part in kept)


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


# ---- guards: these pass -------------------------------------------------------------------


def test_skips_in_several_segments_are_listed_alike_for_any_workers(dataset, tmp_path):
    (dataset / "maps" / f"{stem(0)}.npy").write_bytes(b"not a map")  # the clip's first frame
    (dataset / "maps" / f"{stem(9)}.npy").write_bytes(b"not a map")
    (dataset / "data" / f"{stem(10)}.lines.txt").write_text("1 2 three\n")
    (dataset / "data" / f"{stem(21)}.lines.txt").write_text("1 2 three\n")
    found = []
    for workers in (1, 2, 3):
        folder = tmp_path / f"out{workers}"
        result = api.run(config_for(dataset, workers, on_error="skip"), folder, progress=False)
        found.append((result.skipped, result.counts, {name: (folder / name).read_bytes() for name in OUTPUTS}))
    assert found[0] == found[1] == found[2]
    assert [entry.split(": ")[0].rsplit("/", 1)[-1] for entry in found[0][0]] == [
        "00300.lines.txt:1", "00630.lines.txt:1", "00000.npy", "00270.npy"]


def test_a_size_change_in_a_later_segment_names_its_file(dataset, tmp_path):
    path = dataset / "maps" / f"{stem(17)}.npy"
    np.save(path, np.load(path)[:, ::2, ::2].copy())
    for workers in (1, 2):
        message = error_of(dataset, tmp_path, workers)
        assert message.startswith(f"{path}: maps of shape") and "differ from the clip's first frame" in message
