"""The CULane ground truth drawn once and reused: a later `score culane` of the same frames, labels
and width takes it from the cache (and draws nothing), anything else misses, and an entry that
fails a check is drawn again with a note."""

from __future__ import annotations

import os
import shutil

import numpy as np
import pytest
from click.testing import CliRunner

from roneld_eval import truth_cache
from roneld_eval.cli import main
from roneld_eval.signals import time_limit


def _invoke(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


@pytest.fixture
def cache(tmp_path, monkeypatch):
    folder = tmp_path / "truth"
    monkeypatch.setenv("RONELD_EVAL_TRUTH_CACHE", str(folder))
    return folder


@pytest.fixture(scope="module")
def lane_set(tmp_path_factory):
    out = tmp_path_factory.mktemp("truth") / "set"
    result = _invoke("synth", "--dataset", "culane", "--out", out, "--clips", "30", "--frames", "8", "--maps-format",
                     "lanes")  # 240 frames: two chunks
    assert result.exit_code == 0, result.output
    return out


def _score(data, maps, out, *extra, quiet=True):
    result = _invoke("score", "culane", "--data-root", data, "--pred-root", f"a={maps}", "--pred-root", f"b={maps}",
                     "--iou", "0.3:0.9:0.1", "--workers", "1", *(["--quiet"] if quiet else []), "--out", out, *extra)
    assert result.exit_code == 0, result.output
    return result


def _files(folder):
    return {p.name: p.read_bytes() for p in folder.iterdir() if p.is_file() and not p.name.startswith(".")}


def _entries(cache):
    """The entries in the cache's own folder inside the one RONELD_EVAL_TRUTH_CACHE names."""
    kept = cache / truth_cache.FOLDER_NAME
    return sorted(p for p in kept.iterdir() if p.is_dir() and not p.name.startswith(".")) if kept.exists() else []


def test_a_second_score_takes_the_ground_truth_from_the_cache_and_draws_nothing(lane_set, cache, tmp_path,
                                                                               monkeypatch):
    data, maps = lane_set / "data", lane_set / "maps"
    _score(data, maps, tmp_path / "first")
    assert len(_entries(cache)) == 1
    import roneld_eval.benchmarks.culane.score as scoring

    def no_labels(*args, **kwargs):
        raise AssertionError("the ground truth was read and drawn again")

    monkeypatch.setattr(scoring, "read_frame_labels", no_labels)
    _score(data, maps, tmp_path / "second")
    assert _files(tmp_path / "second") == _files(tmp_path / "first")
    monkeypatch.undo()  # labels read again, and no cache at all
    monkeypatch.setenv("RONELD_EVAL_TRUTH_CACHE", "0")
    _score(data, maps, tmp_path / "uncached")
    assert _files(tmp_path / "uncached") == _files(tmp_path / "first")


def test_an_edited_label_or_another_width_is_another_entry(lane_set, cache, tmp_path):
    data = tmp_path / "data"
    shutil.copytree(lane_set / "data", data)
    maps = lane_set / "maps"
    _score(data, maps, tmp_path / "before")
    label = sorted(data.rglob("*.lines.txt"))[5]
    lines = label.read_text().splitlines()
    label.write_text("\n".join(lines[1:]) + "\n" if len(lines) > 1 else "")  # one lane fewer, same size or not
    _score(data, maps, tmp_path / "after")
    assert len(_entries(cache)) == 2
    assert _files(tmp_path / "after")["official.csv"] != _files(tmp_path / "before")["official.csv"]
    shutil.rmtree(cache)
    _score(data, maps, tmp_path / "fresh")  # the edited labels drawn from scratch: what the cache gave
    assert _files(tmp_path / "fresh") == _files(tmp_path / "after")
    _score(data, maps, tmp_path / "wide", "--width", "16")  # the same labels at another width
    assert len(_entries(cache)) == 2  # the edited labels', and theirs at 16 px


@pytest.mark.parametrize("damage", ["mac", "array", "shape"])
def test_a_damaged_entry_is_drawn_again_with_a_note(lane_set, cache, tmp_path, damage):
    data, maps = lane_set / "data", lane_set / "maps"
    _score(data, maps, tmp_path / "first")
    (entry,) = _entries(cache)
    if damage == "mac":
        (entry / "mac.json").write_text('{"mac": "00"}')
    elif damage == "array":  # a run bound moved: the checksum no longer matches
        lo = np.load(entry / "lo.npy")
        lo[len(lo) // 2] += 1
        np.save(entry / "lo.npy", lo)
    else:
        np.save(entry / "n_gt.npy", np.zeros(3, np.int64))
    result = _score(data, maps, tmp_path / "second", quiet=False)
    assert "the cached ground truth is not used" in result.output and "drawn again" in result.output
    assert _files(tmp_path / "second") == _files(tmp_path / "first")
    assert len(_entries(cache)) == 1  # written again, sound


def test_arrays_that_do_not_add_up_are_refused_even_when_signed():
    truth = truth_cache.from_frames([(0, None)])
    truth_cache._check(truth, 1, 1640, 590)
    bad = truth_cache.TruthRuns(np.array([2]), truth.lane_start, truth.meta, truth.row_start, truth.slots, truth.lo,
                                truth.hi)
    with pytest.raises(ValueError, match="offsets"):
        truth_cache._check(bad, 1, 1640, 590)


def test_shards_reuse_their_own_entries_and_the_oldest_entries_go(lane_set, cache, tmp_path, monkeypatch):
    data, maps = lane_set / "data", lane_set / "maps"
    for k in (1, 2):
        _score(data, maps, tmp_path / f"p{k}", "--shard", f"{k}/2")
    assert len(_entries(cache)) == 2
    first = {p.name: p.stat().st_mtime_ns for p in _entries(cache)}
    _score(data, maps, tmp_path / "again", "--shard", "1/2")  # a hit, not a third entry
    assert len(_entries(cache)) == 2 and {p.name for p in _entries(cache)} == set(first)
    monkeypatch.setattr(truth_cache, "MAX_ENTRIES", 2)
    _score(data, maps, tmp_path / "whole")
    assert len(_entries(cache)) == 2  # the whole list's entry in, the least recently used shard's out


def _key(k: int) -> str:
    return f"{k:064x}"


def test_a_folder_of_the_users_loses_nothing_whatever_the_saves(cache, monkeypatch):
    # RONELD_EVAL_TRUTH_CACHE pointed at a folder holding other things: every non-hidden
    # sub-folder but the four newest was deleted, without a word.
    cache.mkdir()
    mine = {}
    for k in range(6):
        (cache / f"project{k}").mkdir()
        (cache / f"project{k}" / "notes.txt").write_text(f"mine {k}")
        mine[f"project{k}/notes.txt"] = f"mine {k}"
    (cache / _key(99)).mkdir()  # named as an entry would be, but in the user's folder: not the cache's
    (cache / _key(99) / "lo.npy").write_text("mine too")
    mine[f"{_key(99)}/lo.npy"] = "mine too"
    (cache / "todo.txt").write_text("a file")
    mine["todo.txt"] = "a file"
    truth = truth_cache.from_frames([(0, None)])
    notes: list[str] = []
    for k in range(10):
        truth_cache.save(_key(k), truth, notes.append)
    assert notes == []
    assert {name: (cache / name).read_text() for name in mine if (cache / name).is_file()} == mine
    assert sorted(p.name for p in cache.iterdir()) == sorted([f"project{k}" for k in range(6)] + [
        _key(99), "todo.txt", truth_cache.FOLDER_NAME])
    assert [p.name for p in _entries(cache)] == sorted(_key(k) for k in range(6, 10))
    assert (cache / truth_cache.FOLDER_NAME / truth_cache.MARKER_NAME).read_bytes() == truth_cache.MARKER
    assert truth_cache.load(_key(9), 1, 1640, 590, notes.append) is not None and notes == []


def test_a_folder_of_the_caches_name_that_is_not_its_own_is_left_alone(cache):
    theirs = cache / truth_cache.FOLDER_NAME
    theirs.mkdir(parents=True)
    (theirs / "keep.txt").write_text("keep")
    for k in range(6):  # shaped as entries, but in a folder the cache never marked
        (theirs / _key(k)).mkdir()
        (theirs / _key(k) / "mac.json").write_text("{}")
    notes: list[str] = []
    truth_cache.save(_key(7), truth_cache.from_frames([(0, None)]), notes.append)
    assert len(notes) == 1 and "not used for the ground-truth cache" in notes[0] and "did not write" in notes[0]
    assert sorted(p.name for p in theirs.iterdir()) == sorted(["keep.txt"] + [_key(k) for k in range(6)])
    assert truth_cache.load(_key(7), 1, 1640, 590, notes.append) is None and len(notes) == 1


def _fifo(path):
    path.unlink()
    os.mkfifo(path)


def _zero(path):
    path.unlink()
    path.symlink_to("/dev/zero")


def _folder(path):
    path.unlink()
    path.mkdir()
    (path / "x").write_text("x")


def _edited(path):
    data = bytearray(path.read_bytes())
    data[-1] ^= 1
    path.write_bytes(bytes(data))


def _grown(path):
    os.truncate(path, 1 << 40)  # a sparse terabyte: hashed whole before


@pytest.mark.parametrize("name, spoil", [(name, spoil) for name in ("lo.npy", "mac.json")
                                         for spoil in (_fifo, _zero, _folder, _edited, _grown)
                                         if (name, spoil) != ("mac.json", _grown)])  # the old code: all in memory
def test_a_spoilt_entry_file_is_a_note_never_a_hang(lane_set, cache, tmp_path, spoil, name):
    # A FIFO or a link to /dev/zero was hashed before any check: every later score of those
    # frames blocked for ever.
    data, maps = lane_set / "data", lane_set / "maps"
    _score(data, maps, tmp_path / "first")
    (entry,) = {path.parent for path in cache.rglob(truth_cache.MAC_NAME)}
    spoil(entry / name)
    with time_limit(60):  # the old code waits for ever: fail instead
        result = _score(data, maps, tmp_path / "second", quiet=False)
    assert f"note: {entry}: the cached ground truth is not used (" in result.output, result.output
    assert _files(tmp_path / "second") == _files(tmp_path / "first")
    if spoil is _folder:  # not of the cache's shape: left as it is, and drawn each time
        assert (entry / name / "x").read_text() == "x"
    else:  # removed, and written again, sound
        assert len(_entries(cache)) == 1 and (entry / name).is_file() and not (entry / name).is_symlink()
        notes: list[str] = []
        assert truth_cache.load(entry.name, 240, 1640, 590, notes.append) == entry and notes == []
