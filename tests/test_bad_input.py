"""Bad input, interruptions and reproducibility: one clear line, exit 2, nothing written.

Each case corrupts a small valid dataset one way and runs the CLI; the output folder holds an
earlier result that must survive untouched.
"""

import json
import os
import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest
from click.testing import CliRunner

from roneld_eval import api
from roneld_eval.cli import main
from roneld_eval.errors import RunInterrupted
from roneld_eval.benchmarks.culane.synth import synth_culane
from roneld_eval.benchmarks.tusimple.synth import synth_tusimple

SENTINEL = "method,threshold,n_tp,n_gt,accuracy\nearlier,0.30,1,1,1\n"
EARLIER = [".roneld-run.json", "accuracy.csv"]


def earlier_result(out: Path) -> None:
    """An output folder as an earlier run left it: its accuracy.csv and its manifest."""
    out.mkdir(exist_ok=True)
    (out / "accuracy.csv").write_text(SENTINEL)
    (out / ".roneld-run.json").write_text(json.dumps(
        {"format": "roneld-eval output folder", "command": "run", "entries": ["accuracy.csv"]}))


@pytest.fixture(scope="session")
def base_sets(tmp_path_factory):
    root = tmp_path_factory.mktemp("base")
    synth_culane(root / "culane", clips=2, frames=3, seed=3)
    synth_culane(root / "culane-png", clips=1, frames=3, seed=3, maps_format="scnn-png")
    synth_culane(root / "culane-lanes", clips=1, frames=3, seed=3, maps_format="lanes")
    synth_tusimple(root / "tusimple", clips=2, frames=20, seed=3, maps_format="npz")
    return root


@pytest.fixture
def sets(base_sets, tmp_path):
    shutil.copytree(base_sets, tmp_path / "sets")
    out = tmp_path / "out"
    earlier_result(out)
    return tmp_path / "sets", out


def first_map(root: Path, suffix=".npy") -> Path:
    return sorted((root / "maps").rglob(f"*{suffix}"))[0]


def lying_png(width: int, height: int) -> bytes:
    """A PNG with sound chunks whose header promises far more pixels than its data holds."""
    import struct
    import zlib

    def chunk(kind: bytes, body: bytes) -> bytes:
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))

    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(b"\0" * 1000)) + chunk(b"IEND", b""))


def first_labels(root: Path) -> Path:
    return sorted((root / "data").rglob("*.lines.txt"))[0]


def tusimple_labels(root: Path) -> Path:
    return root / "data" / "test_label.json"


def rewrite_label_line(root: Path, change) -> None:
    path = tusimple_labels(root)
    lines = path.read_text().splitlines()
    lines[1] = change(lines[1])
    path.write_text("\n".join(lines) + "\n")


def set_record(key, value):
    def change(line):
        record = json.loads(line)
        if value is None:
            del record[key]
        else:
            record[key] = value
        return json.dumps(record)
    return change


# (name, dataset folder, extra args, corruption(root) -> None, expected text, file named in the message)
CASES = [
    ("dataset root missing", "culane", ["--data-root", "{root}/nowhere"], None, "dataset root not found", "nowhere"),
    ("maps root missing", "culane", ["--maps-root", "{root}/nowhere"], None, "maps root not found", "nowhere"),
    ("list file missing", "culane", ["--list", "{root}/nope.txt"], None, "list file not found", "nope.txt"),
    ("label file missing", "tusimple", ["--list", "{root}/nope.json"], None, "label file not found", "nope.json"),
    ("list file empty", "culane", [],
     lambda r: (r / "data/list/test.txt").write_text("\n"), "names no images", "test.txt"),
    ("list entry outside the root", "culane", [],
     lambda r: (r / "data/list/test.txt").write_text("/../../etc/x.jpg\n"), "outside the dataset root",
     "test.txt:1"),
    ("frame listed twice", "culane", [],
     lambda r: (r / "data/list/test.txt").write_text((r / "data/list/test.txt").read_text() * 2), "listed twice",
     "test.txt"),
    ("maps missing for a frame", "culane", [],
     lambda r: first_map(r).unlink(), "maps missing for 1 frame", "00000.npy"),
    ("clip with maps for part of its frames", "culane", [],
     lambda r: [p.unlink() for p in sorted((r / "maps").rglob("*.npy"))[1:3]], "maps missing for 2 frames", ".npy"),
    ("truncated map", "culane", [],
     lambda r: first_map(r).write_bytes(first_map(r).read_bytes()[:5000]), "truncated or corrupt", "00000.npy"),
    ("map that is not an array", "culane", [],
     lambda r: first_map(r).write_text("hello"), "not a .npy array (it does not start with numpy's magic bytes)",
     "00000.npy"),
    ("map of the wrong dtype", "culane", [],
     lambda r: np.save(first_map(r), np.zeros((4, 288, 800), np.int32)), "dtype int32", "00000.npy"),
    ("map with the wrong channels", "culane", [],
     lambda r: np.save(first_map(r), np.zeros((3, 288, 800), np.uint8)), "has 3 channels, expected 4", "00000.npy"),
    ("map size differing within a clip", "culane", [],
     lambda r: np.save(sorted((r / "maps").rglob("*.npy"))[1], np.zeros((4, 144, 400), np.uint8)),
     "differ from the clip's first frame", "00030.npy"),
    ("map with NaN", "culane", [],
     lambda r: np.save(first_map(r), np.full((4, 288, 800), np.nan, np.float32)), "NaN or infinite", "00000.npy"),
    ("map values outside [0, 1]", "culane", [],
     lambda r: np.save(first_map(r), np.full((4, 288, 800), 2.0, np.float32)), "found 2..2", "00000.npy"),
    ("map PNG whose header claims another size", "culane-png", ["--maps-format", "scnn-png"],
     lambda r: first_map(r, "_1_avg.png").write_bytes(lying_png(8192, 8191)), "not a readable image",
     "00000_1_avg.png"),
    ("map PNG whose header claims 65535x65535", "culane-png", ["--maps-format", "scnn-png"],
     lambda r: first_map(r, "_1_avg.png").write_bytes(lying_png(65535, 65535)),
     "header claims 65535x65535 pixels; maps of more than 67,108,864 pixels are refused", "00000_1_avg.png"),
    ("map PNG bomb in a later frame", "culane-png", ["--maps-format", "scnn-png"],
     lambda r: sorted((r / "maps").rglob("*_2_avg.png"))[-1].write_bytes(lying_png(40000, 14400)),
     "header claims 40000x14400", "00060_2_avg.png"),
    ("map PNG bomb of the preset's aspect ratio", "culane-png", ["--maps-format", "scnn-png"],
     lambda r: first_map(r, "_1_avg.png").write_bytes(lying_png(40000, 14400)), "header claims 40000x14400",
     "00000_1_avg.png"),
    ("existence with the wrong count", "culane-png", ["--maps-format", "scnn-png"],
     lambda r: first_map(r, ".exist.txt").write_text("1 1 1\n"), "existence has 3 values", "00000.exist.txt"),
    ("existence that is not numbers", "culane-png", ["--maps-format", "scnn-png"],
     lambda r: first_map(r, ".exist.txt").write_text("1 one 1 1\n"), "'one' is not a number", "00000.exist.txt"),
    ("labels with an odd number of values", "culane", [],
     lambda r: first_labels(r).write_text("1 590 2\n"), "odd number of values", "00000.lines.txt:1"),
    ("labels that are not numbers", "culane", [],
     lambda r: first_labels(r).write_text("1 590 2 580\n3 x\n"), "'x' is not a number", "00000.lines.txt:2"),
    ("detector lanes at 1e308", "culane-lanes", ["--maps-format", "lanes"],
     lambda r: first_map(r, ".lines.txt").write_text("1e308 590 100 300\n"), "lies more than 2^24 px",
     "00000.lines.txt:1"),
    ("labels far outside the image", "culane", [],
     lambda r: first_labels(r).write_text("1 590 90000 580\n"), "far outside the 1640x590 image", "00000.lines.txt:1"),
    ("TuSimple line that is not JSON", "tusimple", [],
     lambda r: rewrite_label_line(r, lambda line: line[:-5]), "not valid JSON", "test_label.json:2"),
    ("TuSimple line without a key", "tusimple", [],
     lambda r: rewrite_label_line(r, set_record("h_samples", None)), "missing key 'h_samples'", "test_label.json:2"),
    ("TuSimple lanes and h_samples differ", "tusimple", [],
     lambda r: rewrite_label_line(r, set_record("h_samples", [160, 170])), "but h_samples has 2", "test_label.json:2"),
    ("TuSimple x of 400 digits", "tusimple", [],
     lambda r: rewrite_label_line(r, lambda line: line.replace('"lanes": [[', '"lanes": [[' + "9" * 400 + ", ", 1)),
     "not a finite number", "test_label.json:2"),
    ("TuSimple clip with fewer than 20 frames", "tusimple", [],
     lambda r: sorted((r / "maps").rglob("*.npz"))[5].unlink(), "needs maps for all its 20 frames", ".npz"),
    ("TuSimple frame labelled twice", "tusimple", [],
     lambda r: tusimple_labels(r).write_text(tusimple_labels(r).read_text().splitlines()[0] + "\n"
                                            + tusimple_labels(r).read_text()), "labelled twice", "test_label.json:2"),
]


@pytest.mark.parametrize("name, folder, extra, corrupt, expected, named", CASES, ids=[c[0] for c in CASES])
def test_bad_input(sets, name, folder, extra, corrupt, expected, named):
    root_all, out = sets
    root = root_all / folder
    if corrupt is not None:
        corrupt(root)
    dataset = "tusimple" if folder == "tusimple" else "culane"
    args = ["run", "--dataset", dataset, "--data-root", str(root / "data"), "--maps-root", str(root / "maps"),
            "--maps-format", "npz" if folder == "tusimple" else "npy", "--workers", "1", "--quiet", "--out", str(out)]
    args += [a.format(root=root) for a in extra]
    # Later options win: the case's own --data-root/--maps-root/--maps-format replace the defaults.
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 2, result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), result.output
    assert expected in lines[0] and named in lines[0], lines[0]
    assert "Traceback" not in result.output
    assert (out / "accuracy.csv").read_text() == SENTINEL
    assert sorted(p.name for p in out.iterdir()) == EARLIER


def test_output_folder_that_is_not_writable(sets, tmp_path):
    root, _ = sets
    blocker = tmp_path / "a-file"
    blocker.write_text("")
    result = CliRunner().invoke(main, ["run", "--out", str(blocker / "results"), "--quiet"])
    assert result.exit_code == 2 and "cannot write results here" in result.output and "a-file" in result.output


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="needs /dev/full (writes fail with ENOSPC)")
def test_disk_full_while_writing_leaves_earlier_results(sets, monkeypatch):
    _, out = sets
    from roneld_eval.report import write

    original = write.Staging.file

    def full_disk(self, name):  # the per-frame table is written to a device that is always full
        return Path("/dev/full") if name == "per_frame.csv" else original(self, name)

    monkeypatch.setattr(write.Staging, "file", full_disk)
    result = CliRunner().invoke(main, ["run", "--out", str(out), "--quiet", "--workers", "1"])
    assert result.exit_code == 2 and "No space left on device" in result.output
    assert "per_frame.csv: cannot write" in result.output and "Traceback" not in result.output
    assert (out / "accuracy.csv").read_text() == SENTINEL
    assert sorted(p.name for p in out.iterdir()) == EARLIER


def stage_on_full_disk(monkeypatch, name: str) -> None:
    """The staged file `name` leads to a device that is always full (writes fail with ENOSPC)."""
    from roneld_eval.report import write

    original = write.Staging.file

    def full_disk(self, wanted):
        path = original(self, wanted)
        if wanted == name:
            path.symlink_to("/dev/full")
        return path

    monkeypatch.setattr(write.Staging, "file", full_disk)


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="needs /dev/full (writes fail with ENOSPC)")
@pytest.mark.parametrize("name, options", [
    ("accuracy_curve.svg", []),
    ("categories.png", []),  # drawn in a forked process, then again here when that fails
    ("lanes/baseline/predictions.json", ["--dataset", "tusimple", "--save-lanes"]),  # appended frame by frame
])
def test_disk_full_names_the_file_in_the_output_folder(sets, monkeypatch, name, options):
    _, out = sets
    stage_on_full_disk(monkeypatch, name)
    result = CliRunner().invoke(main, ["run", "--out", str(out), "--quiet", "--workers", "1", *options])
    assert result.exit_code == 2, result.output
    assert result.output == f"error: {out / name}: cannot write: No space left on device\n"
    assert (out / "accuracy.csv").read_text() == SENTINEL
    assert sorted(p.name for p in out.iterdir()) == EARLIER


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="needs /dev/full (writes fail with ENOSPC)")
def test_debug_shows_where_a_renamed_write_error_came_from(sets, monkeypatch):
    _, out = sets
    stage_on_full_disk(monkeypatch, "accuracy_curve.svg")
    result = CliRunner().invoke(main, ["run", "--out", str(out), "--quiet", "--workers", "1", "--debug"])
    assert result.exit_code == 2
    assert "in save_figure" in result.output and ".staging-" not in result.output.splitlines()[-1]
    last = result.output.splitlines()[-1]
    assert last == f"error: {out / 'accuracy_curve.svg'}: cannot write: No space left on device"


# ---- skipping ------------------------------------------------------------------------------


def _synth_set(out: Path) -> dict:
    assert CliRunner().invoke(main, ["synth", "--dataset", "openlane", "--out", str(out)]).exit_code == 0
    return {path: path.read_bytes() for path in out.rglob("*") if path.is_file()}


def test_disk_full_while_synth_writes_a_label_names_it(tmp_path, monkeypatch):
    # It said "error: [Errno 28] No space left on device", naming no file.
    import errno

    out = tmp_path / "set"
    earlier = _synth_set(out)
    original = Path.write_text

    def full(self, data, *args, **kwargs):
        if self.name == "155000100000.json":
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))  # as a full disk: no file named
        return original(self, data, *args, **kwargs)

    monkeypatch.setattr(Path, "write_text", full)
    result = CliRunner().invoke(main, ["synth", "--dataset", "openlane", "--out", str(out), "--seed", "1"])
    monkeypatch.undo()
    named = out / "labels" / "segment-01000" / "155000100000.json"
    assert result.exit_code == 2 and result.output == f"error: {named}: cannot write: No space left on device\n"
    assert {path: path.read_bytes() for path in out.rglob("*") if path.is_file()} == earlier  # no lock either


def test_a_synth_whose_pictures_cannot_be_written_stops_and_names_one(tmp_path):
    # cv2.imwrite returned False on a failed write: synth committed a set of truncated PNG maps, exit 0.
    import subprocess
    import sys

    resource = pytest.importorskip("resource")  # POSIX

    def small_files_only():
        resource.setrlimit(resource.RLIMIT_FSIZE, (4096, 4096))  # the PNG maps are larger; Python ignores SIGXFSZ

    out = tmp_path / "set"
    done = subprocess.run([sys.executable, "-m", "roneld_eval", "synth", "--dataset", "culane", "--maps-format",
                           "scnn-png", "--out", str(out)], capture_output=True, text=True, timeout=300,
                          preexec_fn=small_files_only)
    assert done.returncode == 2, (done.stdout, done.stderr)
    lines = done.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"error: {out / 'maps'}/") and lines[0].endswith(
        "_avg.png: cannot write: File too large"), done.stderr
    assert not out.exists()  # nothing committed, the new folder removed again


def test_skip_mode_skips_and_lists(sets):
    root_all, out = sets
    root = root_all / "culane"
    first_map(root).write_text("hello")  # a bad map: that frame is skipped
    sorted((root / "data").rglob("*.lines.txt"))[1].write_text("1 x\n")  # bad labels: skipped too
    result = CliRunner().invoke(main, ["run", "--data-root", str(root / "data"), "--maps-root", str(root / "maps"),
                                       "--on-error", "skip", "--workers", "1", "--quiet", "--out", str(out)])
    assert result.exit_code == 0, result.output
    summary = json.loads((out / "summary.json").read_text())
    assert len(summary["skipped"]) == 2
    assert any("labels skipped" in s for s in summary["skipped"])
    assert "skipped 2" in result.output
    assert any("frame skipped" in s and "00000.npy" in s for s in summary["skipped"])
    assert summary["counts"]["frames"] == 6 - 2


def test_skip_mode_skips_clips_without_all_maps(sets):
    root_all, out = sets
    root = root_all / "tusimple"
    sorted((root / "maps").rglob("*.npz"))[3].unlink()
    result = CliRunner().invoke(main, ["run", "--dataset", "tusimple", "--data-root", str(root / "data"),
                                       "--maps-root", str(root / "maps"), "--maps-format", "npz", "--on-error", "skip",
                                       "--workers", "1", "--quiet", "--out", str(out)])
    assert result.exit_code == 0, result.output
    summary = json.loads((out / "summary.json").read_text())
    assert summary["counts"]["clips"] == 1 and "clip skipped" in summary["skipped"][0]


def test_a_run_that_scores_nothing_fails_and_keeps_the_earlier_results(sets):
    # Every clip skipped gave "0 clips, 0 frames", tables of n/a and exit 0.
    root_all, out = sets
    root = root_all / "culane"
    for path in (root / "maps").rglob("00000.npy"):
        path.unlink()  # every clip lacks a map: every clip is skipped
    result = CliRunner().invoke(main, ["run", "--data-root", str(root / "data"), "--maps-root", str(root / "maps"),
                                       "--on-error", "skip", "--workers", "1", "--quiet", "--out", str(out)])
    assert result.exit_code == 2, result.output
    assert result.output.count("\n") == 1 and "nothing was scored: every labelled frame was skipped (2 skipped, " \
        "first: " in result.output
    assert (out / "accuracy.csv").read_text() == SENTINEL


def test_pngs_without_their_existence_file_are_named_as_such(sets):
    root_all, out = sets
    root = root_all / "culane-png"
    for path in (root / "maps").rglob("*.exist.txt"):
        path.unlink()
    result = CliRunner().invoke(main, ["run", "--data-root", str(root / "data"), "--maps-root", str(root / "maps"),
                                       "--maps-format", "scnn-png", "--workers", "1", "--quiet", "--out", str(out)])
    assert result.exit_code == 2, result.output
    assert "00000.exist.txt (00000_1_avg.png is there, its existence file is not" in result.output


def sparse(path: Path, size: int) -> None:
    """Make `path` a sparse file of `size` bytes (nothing written: reading it would take minutes)."""
    with open(path, "wb") as handle:
        handle.truncate(size)


TEN_GB = 10 * 10**9


@pytest.mark.parametrize("folder, extra, target, expected", [
    ("culane", [], first_labels, "a label, lane, existence or list file may have at most 16,777,216 bytes"),
    ("culane", [], first_map, "a map file (.npy, .npz or one of its members, .png) may have at most"),
    ("culane-png", ["--maps-format", "scnn-png"], lambda r: first_map(r, "_1_avg.png"), "a map file"),
    ("culane-png", ["--maps-format", "scnn-png"], lambda r: first_map(r, ".exist.txt"), "a label, lane"),
    ("tusimple", [], tusimple_labels, "a JSON-lines label or prediction file may have at most 268,435,456 bytes"),
])
def test_a_huge_input_file_is_refused_unread(sets, folder, extra, target, expected):
    # A 10 GB sparse .lines.txt reached 23 GB of memory before it was killed.
    root_all, out = sets
    root = root_all / folder
    path = target(root)
    sparse(path, TEN_GB)
    dataset = ["--dataset", "tusimple", "--maps-format", "npz"] if folder == "tusimple" else []
    result = CliRunner().invoke(main, ["run", *dataset, "--data-root", str(root / "data"), "--maps-root",
                                       str(root / "maps"), "--workers", "1", "--quiet", "--out", str(out), *extra])
    assert result.exit_code == 2, result.output
    assert result.output.count("\n") == 1 and f"{path}: too large (10,000,000,000 bytes): {expected}" in result.output
    assert "RONELD_EVAL_MAX_" in result.output
    assert (out / "accuracy.csv").read_text() == SENTINEL


def test_a_size_limit_can_be_raised_and_a_bad_one_is_named(sets, monkeypatch):
    root_all, out = sets
    root = root_all / "culane"
    args = ["run", "--data-root", str(root / "data"), "--maps-root", str(root / "maps"), "--workers", "1",
            "--quiet", "--out", str(out)]
    monkeypatch.setenv("RONELD_EVAL_MAX_MAP_MIB", "0.5")  # below one 4x288x800 map (921,728 bytes)
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 2 and "may have at most 524,288 bytes" in result.output, result.output
    monkeypatch.setenv("RONELD_EVAL_MAX_MAP_MIB", "lots")
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 2 and "RONELD_EVAL_MAX_MAP_MIB='lots': give the largest size in MiB" in result.output
    for odd in ("1e-9", "1_0", "-1", "nan"):
        monkeypatch.setenv("RONELD_EVAL_MAX_MAP_MIB", odd)
        assert "give the largest size in MiB" in CliRunner().invoke(main, args).output, odd
    monkeypatch.setenv("RONELD_EVAL_MAX_MAP_MIB", "1")
    assert CliRunner().invoke(main, args).exit_code == 0
    # A bound far past the machine's memory is never allocated at once (read(n) would).
    monkeypatch.setenv("RONELD_EVAL_MAX_MAP_MIB", "100000000")
    monkeypatch.setenv("RONELD_EVAL_MAX_TEXT_MIB", "100000000")
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 0, result.output


def _one_frame_of_1001_lanes(tmp_path: Path) -> None:
    """A CULane set of one frame (gt/, list.txt) whose prediction (pred/) holds 1,001 lanes."""
    for folder, text in (("gt", "100 580 200 400 300 300\n"), ("pred", "100 580 200 400\n" * 1001)):
        (tmp_path / folder / "d").mkdir(parents=True)
        (tmp_path / folder / "d" / "f.lines.txt").write_text(text)
    (tmp_path / "list.txt").write_text("d/f.jpg\n")


def test_a_lane_file_of_too_many_lanes_is_refused_and_the_bound_can_be_raised(tmp_path, monkeypatch):
    # 90,000 two-point lanes in 2 MB, well under the 16 MiB size bound, took 1.1 GB and 4 s for one frame.
    _one_frame_of_1001_lanes(tmp_path)
    args = ["score", "culane", "--data-root", str(tmp_path / "gt"), "--pred-root", str(tmp_path / "pred"),
            "--list", str(tmp_path / "list.txt"), "--quiet", "--out", str(tmp_path / "out")]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 2 and result.output.count("\n") == 1, result.output
    assert (f"{tmp_path / 'pred' / 'd' / 'f.lines.txt'}: too many lanes (1,001): one frame's labels or predictions "
            "may hold at most 1,000 lanes (raise it with RONELD_EVAL_MAX_LANES=N)") in result.output
    assert not (tmp_path / "out").exists()
    monkeypatch.setenv("RONELD_EVAL_MAX_LANES", "1001")
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 0 and (tmp_path / "out" / "official.csv").is_file(), result.output
    for odd in ("many", "0", "1e3", "-5", "\u00b2", "9999999999"):
        monkeypatch.setenv("RONELD_EVAL_MAX_LANES", odd)
        result = CliRunner().invoke(main, args)
        assert result.exit_code == 2, odd
        assert (f"RONELD_EVAL_MAX_LANES={odd!r}: give the most lanes one frame may hold, a whole number from 1 to "
                "999,999,999") in result.output, odd


def test_a_command_that_fails_into_a_new_nested_folder_leaves_none_of_it(tmp_path):
    # `--out parts/1 --shard 1/2` left parts/ behind: only the folder itself was removed.
    _one_frame_of_1001_lanes(tmp_path)
    (tmp_path / "kept").mkdir()
    (tmp_path / "empty").mkdir()  # given as --out itself: a folder the user made is never removed
    for out in (tmp_path / "parts" / "1", tmp_path / "kept" / "a" / "b", tmp_path / "empty",
                tmp_path / "via" / ".." / "made"):
        result = CliRunner().invoke(main, ["score", "culane", "--data-root", str(tmp_path / "gt"), "--pred-root",
                                           str(tmp_path / "pred"), "--list", str(tmp_path / "list.txt"), "--quiet",
                                           "--shard", "1/2", "--out", str(out)])
        assert result.exit_code == 2 and "too many lanes" in result.output, result.output
    assert not (tmp_path / "parts").exists() and not (tmp_path / "via").exists()
    assert not (tmp_path / "made").exists()
    assert (tmp_path / "kept").is_dir() and not any((tmp_path / "kept").iterdir())  # there before: kept
    assert (tmp_path / "empty").is_dir()


@pytest.mark.parametrize("dataset, key, extra", [
    ("openlane", "lane_lines", []),
    ("curvelanes", "Lines", ["--image-root", "images"]),
])
def test_a_json_prediction_of_too_many_lanes_is_refused(tmp_path, dataset, key, extra):
    # CurveLanes: 200,000 two-point lanes (9 MB) took 111 s and 9.7 GB; OpenLane 300,000, 1.7 GB.
    assert CliRunner().invoke(main, ["synth", "--dataset", dataset, "--out", str(tmp_path), "--clips", "1",
                                     "--maps-format", "lanes"]).exit_code == 0
    path = sorted((tmp_path / "predictions").rglob("*.json"))[0]
    record = json.loads(path.read_text())
    record[key] = record[key][:1] * 1001
    path.write_text(json.dumps(record))
    result = CliRunner().invoke(main, ["score", dataset, "--labels", str(tmp_path / "labels"), "--pred-root",
                                       str(tmp_path / "predictions"), "--workers", "1", "--quiet",
                                       *[str(tmp_path / arg) if arg == "images" else arg for arg in extra]])
    assert result.exit_code == 2 and result.output.count("\n") == 1, result.output
    assert f"{path}: too many lanes (1,001): one frame's labels or predictions may hold at most 1,000" in result.output


def test_a_tusimple_frame_of_too_many_lanes_is_refused(tmp_path):
    rows = list(range(160, 720, 10))
    label = {"lanes": [[500] * 56], "h_samples": rows, "raw_file": "clips/a/20.jpg"}
    (tmp_path / "labels.json").write_text(json.dumps(label) + "\n")
    (tmp_path / "pred.json").write_text(json.dumps({"raw_file": "clips/a/20.jpg", "lanes": [[500] * 56] * 1001}) + "\n")
    result = CliRunner().invoke(main, ["score", "tusimple", "--labels", str(tmp_path / "labels.json"), "--pred",
                                       str(tmp_path / "pred.json"), "--quiet"])
    assert result.exit_code == 2 and result.output.count("\n") == 1, result.output
    assert f"{tmp_path / 'pred.json'}:1: too many lanes (1,001): one frame's labels" in result.output


def test_an_instance_mask_of_too_many_grey_values_is_refused_before_fitting_them(tmp_path):
    # Each grey value of a VIL-100 mask is fitted and drawn as a lane: an RGB mask of 51,360 two-row
    # blobs took 3 s for one 1280x720 frame, and a mask may hold 67 M pixels.
    cases = Path(__file__).parent / "golden" / "vil100" / "acc_cases"
    shutil.copytree(cases / "pred_png", tmp_path / "pred")
    path = sorted((tmp_path / "pred").rglob("*.png"))[0]
    mask = np.zeros((1080, 1920, 3), np.uint8)
    for k in range(1001):  # 1,001 colours of distinct greys, each a short vertical stroke
        row, column = divmod(k, 100)
        mask[100 + 60 * row:140 + 60 * row, 10 + 19 * column:14 + 19 * column] = (k % 256, k // 256, 40)
    assert cv2.imwrite(str(path), mask)
    result = CliRunner().invoke(main, ["score", "vil100", "--labels", str(cases / "anno_txt"), "--pred-root",
                                       str(tmp_path / "pred"), "--pred-format", "png", "--sizes",
                                       str(cases / "test_sizes.json"), "--workers", "1", "--quiet",
                                       "--out", str(tmp_path / "out")])
    assert result.exit_code == 2 and result.output.count("\n") == 1, result.output
    assert (f"{path}: too many lanes (1,001 grey values): one frame's labels or predictions may hold at most "
            "1,000 lanes") in result.output
    assert not (tmp_path / "out").exists()


def _npy_bytes(array: np.ndarray) -> bytes:
    import io

    buffer = io.BytesIO()
    np.save(buffer, array)
    return buffer.getvalue()


def _text_member_archive(path: Path) -> None:
    import zipfile

    with zipfile.ZipFile(path, "w") as archive:
        archive.writestr("probs.npy", "hello world text")


@pytest.mark.parametrize("damage, said", [
    # np.load handed the member's bytes on (AttributeError: 'bytes' object has no attribute 'ndim')
    (_text_member_archive, "its member probs.npy is not a .npy array"),
    # np.load returned the array, which `with` refused (TypeError: ... context manager protocol)
    (lambda path: path.write_bytes(_npy_bytes(np.zeros((4, 8, 8), np.uint8))),
     "is a .npy array under an .npz name: save it as .npy (and use --maps-format npy)"),
    # np.load took it for a pickle and advised loading it unsafely (allow_pickle=)
    (lambda path: path.write_text("some text\n"), "not an .npz archive (it does not start as a zip archive does)"),
    (lambda path: path.write_text("PKhello"), "not an .npz archive (it does not start as a zip archive does)"),
], ids=["text member", "npy array", "text", "PK text"])
def test_an_npz_that_is_no_archive_of_arrays_is_one_line_in_the_run_and_its_dry_run(tmp_path, damage, said):
    made = synth_culane(tmp_path / "set", clips=1, frames=3, seed=1, maps_format="npz")
    first = sorted(made.maps_root.rglob("*.npz"))[0]
    damage(first)
    args = ["run", "--data-root", str(made.data_root), "--maps-root", str(made.maps_root), "--maps-format", "npz",
            "--workers", "1", "--quiet", "--out", str(tmp_path / "out")]
    for extra in ([], ["--dry-run"]):  # the dry run said all was well
        result = CliRunner().invoke(main, args + extra)
        assert result.exit_code == 2 and result.output.count("\n") == 1, result.output
        assert f"{first}: {said}" in result.output and "allow_pickle" not in result.output
    assert not (tmp_path / "out").exists()


def test_an_npz_member_that_inflates_past_the_bound_is_refused_before_inflating(sets, monkeypatch):
    root_all, out = sets
    root = root_all / "tusimple"
    path = sorted((root / "maps").rglob("*.npz"))[0]
    np.savez_compressed(path, probs=np.zeros((4, 1024, 1024), np.uint8))  # 4 MiB inflated, a few kB stored
    monkeypatch.setenv("RONELD_EVAL_MAX_MAP_MIB", "2")
    result = CliRunner().invoke(main, ["run", "--dataset", "tusimple", "--data-root", str(root / "data"),
                                       "--maps-root", str(root / "maps"), "--maps-format", "npz", "--workers", "1",
                                       "--quiet", "--out", str(out)])
    assert result.exit_code == 2, result.output
    assert f"{path}: its member 'probs.npy' inflates to 4,194,432 bytes: a map file" in result.output


def test_an_npz_member_whose_header_claims_more_than_it_holds_is_named(sets):
    # 191 bytes claiming 40 GB: np.load allocated the claim first ("out of memory", no file named).
    import io
    import zipfile

    root_all, out = sets
    root = root_all / "tusimple"
    path = sorted((root / "maps").rglob("*.npz"))[0]
    header = io.BytesIO()
    np.lib.format.write_array_header_1_0(header, {"descr": "|u1", "fortran_order": False, "shape": (4, 10**5, 10**5)})
    with zipfile.ZipFile(path, "w") as archive:
        archive.writestr("probs.npy", header.getvalue() + bytes(100))
    result = CliRunner().invoke(main, ["run", "--dataset", "tusimple", "--data-root", str(root / "data"),
                                       "--maps-root", str(root / "maps"), "--maps-format", "npz", "--workers", "1",
                                       "--quiet", "--out", str(out)])
    assert result.exit_code == 2, result.output
    assert f"{path}: its array 'probs' claims shape (4, 100000, 100000) (40,000,000,000 bytes) but holds 100" \
        in result.output


def test_score_tusimple_refuses_a_huge_prediction_file(tmp_path):
    labels, pred = tmp_path / "labels.json", tmp_path / "pred.json"
    labels.write_text("")
    sparse(pred, TEN_GB)
    result = CliRunner().invoke(main, ["score", "tusimple", "--labels", str(labels), "--pred", str(pred)])
    assert result.exit_code == 2 and f"{pred}: too large (10,000,000,000 bytes)" in result.output, result.output


# ---- interruptions -------------------------------------------------------------------------


def _config(root: Path, workers: int = 1):
    return api.default_config("culane").with_overrides(**{
        "dataset.data_root": str(root / "data"), "maps.root": str(root / "maps"), "workers": workers,
        "pft_ablation": True})


def test_interrupted_run_writes_nothing_and_resume_gives_the_same_numbers(sets, monkeypatch, tmp_path):
    root_all, out = sets
    root = root_all / "culane"
    synth_culane(root, clips=5, frames=3, seed=4)
    clean = tmp_path / "clean"
    api.run(_config(root), clean, progress=False)

    from conftest import interrupt_after

    from roneld_eval import evaluation

    original = evaluation.evaluate_clip
    interrupt_after(monkeypatch, 2)
    with pytest.raises(RunInterrupted) as caught:
        api.run(_config(root), out, progress=False)
    assert caught.value.exit_code == 130
    assert "2 finished clips kept" in str(caught.value) and "--resume" in str(caught.value)
    assert sorted(p.name for p in out.iterdir()) == sorted(EARLIER + [".roneld-cache"])
    assert (out / "accuracy.csv").read_text() == SENTINEL

    calls: list[str] = []
    monkeypatch.setattr(evaluation.one_clip, "evaluate_clip",
                        lambda clip, context, *rest: calls.append(clip.clip_id) or original(clip, context, *rest))
    api.run(_config(root), out, progress=False, resume=True)
    assert len(calls) == 3  # only the clips that had not finished
    for name in ("accuracy.csv", "per_frame.csv", "official.csv"):
        assert (out / name).read_bytes() == (clean / name).read_bytes()
    assert not (out / ".roneld-cache").exists()  # kept only while unfinished


@pytest.mark.parametrize("number", [2, 15])  # SIGINT, SIGTERM
def test_an_interruption_that_c_code_replaced_with_its_own_error_is_the_interruption(tmp_path, monkeypatch, number):
    # matplotlib's Agg renderer, cut short while drawing a run's figure, raises "ValueError:
    # Invalid bounding box" and drops the interruption: a traceback and exit 1 (2 of 53 `run`
    # signalled in their last second), and the finished clips were dropped as after a bug.
    from roneld_eval.report import figure_files

    original, here = figure_files.write_png, os.getpid()

    def swallowing(figure, path):
        if os.getpid() != here:  # a figure drawn in a forked process
            return original(figure, path)
        try:
            os.kill(here, number)
        except KeyboardInterrupt:
            pass  # as C code that clears the error it was handed and sets its own
        raise ValueError("Invalid bounding box")

    monkeypatch.setattr(figure_files, "write_png", swallowing)
    out = tmp_path / "out"
    result = CliRunner().invoke(main, ["run", "--workers", "1", "--quiet", "--out", str(out)])
    said = "interrupted" if number == 2 else "terminated (SIGTERM)"
    assert result.exit_code == 128 + number and result.output.count("\n") == 1, result.output
    assert result.output.startswith(f"error: {said}: no result was written; ") and "--resume" in result.output
    assert [path.name for path in out.iterdir()] == [".roneld-cache"]  # the finished clips, for --resume


def test_ctrl_c_inside_a_numba_kernel_keeps_the_finished_clips(sets, monkeypatch, tmp_path):
    """numba's compiled code calls back into Python, where Ctrl-C may land: it came out of the
    kernel as a SystemError, printed as a traceback, and the finished clips were dropped as after
    a bug (2 of 40 Ctrl-C's of a run in one process). It is the interruption it is."""
    from conftest import interrupt_after

    root = sets[0] / "culane"
    synth_culane(root, clips=5, frames=3, seed=4)
    interrupt_after(monkeypatch, 2, inside_kernel=True)
    result = CliRunner().invoke(main, ["run", "--data-root", str(root / "data"), "--maps-root",
                                       str(root / "maps"), "--workers", "1", "--quiet", "--out", str(tmp_path / "o")])
    assert result.exit_code == 130, result.output
    assert "Traceback" not in result.output and "SystemError" not in result.output
    assert "2 finished clips kept" in result.output and "--resume" in result.output
    assert (tmp_path / "o" / ".roneld-cache").is_dir()


@pytest.mark.parametrize("raised", [SystemError("CPUDispatcher(<function lane_set_runs>) returned a result with an "
                                                 "exception set"), ImportError("initialization failed")])
def test_a_command_interrupted_inside_c_code_says_so(capsys, raised):
    """Any command (score, show, synth): Ctrl-C inside a numba kernel or an extension module's
    initialisation comes out as another exception it caused; the one line of an interruption,
    not a traceback."""
    from roneld_eval import cli

    def kernel_interrupted():
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt as error:
            raise raised from error

    def broken():
        raise SystemError("a bug of its own")

    with pytest.raises(SystemExit) as stopped:
        cli._guard(kernel_interrupted, False)
    assert stopped.value.code == 130 and capsys.readouterr().err == "interrupted: no result was written\n"
    with pytest.raises(SystemError, match="a bug of its own"):
        cli._guard(broken, False)


def test_ctrl_c_on_the_command_line(sets, monkeypatch):
    _, out = sets

    def interrupted(*args, **kwargs):
        raise RunInterrupted("interrupted: no result was written; 2 finished clips kept in x", exit_code=130)

    monkeypatch.setattr(api, "run", interrupted)
    result = CliRunner().invoke(main, ["run", "--out", str(out), "--quiet"])
    assert result.exit_code == 130 and "interrupted" in result.output and "Traceback" not in result.output


def test_a_killed_worker_ends_the_run_clearly(sets, monkeypatch):
    root_all, out = sets
    root = root_all / "culane"
    from roneld_eval import evaluation

    original = evaluation.evaluate_clip
    parent = os.getpid()

    def dying(clip, context, *rest):
        if os.getpid() != parent and clip.clip_id.endswith("0204.MP4"):
            os._exit(9)  # as if killed
        return original(clip, context, *rest)

    monkeypatch.setattr(evaluation.one_clip, "evaluate_clip", dying)
    with pytest.raises(RunInterrupted) as caught:
        api.run(_config(root, workers=2), out, progress=False)
    message = str(caught.value)
    assert "worker process died" in message and "no result was written" in message
    # Finished clips, if any finished before the pool broke, are offered to --resume.
    assert ("--resume" in message) == ("finished clip" in message)
    assert (out / "accuracy.csv").read_text() == SENTINEL


# ---- unusual but valid ---------------------------------------------------------------------


def test_unusual_valid_input(sets, tmp_path):
    root_all, _ = sets
    root = root_all / "culane"
    maps = sorted((root / "maps").rglob("*.npy"))
    np.save(maps[0], np.zeros((4, 288, 800), np.uint8))  # all-zero maps: no lanes
    labels = sorted((root / "data").rglob("*.lines.txt"))
    labels[1].write_text("")  # a frame without ground truth
    labels[2].write_text(labels[2].read_text().splitlines()[1] + "\n")  # a one-lane road
    for path in maps[3:]:  # a whole clip with maps of another size
        np.save(path, np.ascontiguousarray(np.load(path)[:, ::2, ::2]))
    result = api.run(_config(root), tmp_path / "o", progress=False)
    assert result.counts["frames"] == 6
    per_frame = result.per_frame
    assert (per_frame[per_frame["frame"].str.endswith("00000.jpg")]["iou"] == 0).any()
    assert result.accuracy["n_gt"].iloc[0] == len(per_frame) // 3


def test_same_numbers_on_every_run(sets, tmp_path):
    root_all, _ = sets
    root = root_all / "culane"
    api.run(_config(root, workers=2), tmp_path / "a", progress=False)
    api.run(_config(root, workers=1), tmp_path / "b", progress=False)
    for name in ("accuracy.csv", "per_frame.csv", "official.csv"):
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes()
    # The configurations differ only in the number of workers.
    a, b = ((tmp_path / run / "config.toml").read_text().splitlines() for run in "ab")
    assert [x for x in a if not x.startswith("workers")] == [x for x in b if not x.startswith("workers")]
    assert "workers = 2" in a and "workers = 1" in b


def test_a_killed_worker_ends_scoring_clearly(tmp_path, monkeypatch):
    from roneld_eval.benchmarks.culane.synth import synth_lane_files

    from roneld_eval.benchmarks.culane import score

    gt, pred = synth_lane_files(tmp_path / "lanes", frames=450, seed=1)
    original = score.frame_result
    parent = os.getpid()

    def dying(*args, **kwargs):
        if os.getpid() != parent:
            os._exit(9)  # as if killed
        return original(*args, **kwargs)

    # Workers are forked, so they see the patched name that _score_frames looks up.
    monkeypatch.setattr(score, "frame_result", dying)
    with pytest.raises(RunInterrupted, match="worker process died .* while scoring"):
        api.score_culane(gt, pred, workers=2, out=tmp_path / "out")
    assert not (tmp_path / "out" / "official.csv").exists()


@pytest.mark.filterwarnings("error::pytest.PytestUnhandledThreadExceptionWarning")  # pytest's own hook sees it
def test_a_signal_while_scoring_leaves_no_pool_traceback(tmp_path, monkeypatch, capfd):
    # Python 3.11's pool manager thread died with InvalidStateError on the futures that
    # pool.map had cancelled, printing a traceback under the interruption's one line.
    import signal
    import threading
    import time

    from roneld_eval.benchmarks.culane import score
    from roneld_eval.signals import Terminated
    from roneld_eval.benchmarks.culane.synth import synth_lane_files

    gt, pred = synth_lane_files(tmp_path / "lanes", frames=1200, seed=1)
    original = score.frame_result
    parent = os.getpid()

    def slow(*args, **kwargs):
        if os.getpid() != parent:
            time.sleep(0.005)
        return original(*args, **kwargs)

    monkeypatch.setattr(score, "frame_result", slow)
    threads_before = set(threading.enumerate())
    timer = threading.Timer(1.0, os.kill, (parent, signal.SIGTERM))
    timer.start()
    try:
        with pytest.raises(Terminated):
            api.score_culane(gt, pred, workers=2, out=tmp_path / "out")
    finally:
        timer.cancel()
    for thread in set(threading.enumerate()) - threads_before:
        if not thread.daemon:  # the pool's manager thread, which ends after the workers
            thread.join(30)
    assert "Traceback" not in capfd.readouterr().err
    assert not (tmp_path / "out").exists()


def test_a_first_map_that_does_not_decode_is_skipped_whatever_its_header_claims(sets):
    # The run's main process takes the maps' size from the first PNG's header; a header that
    # disagrees with the configuration must not stop a run that skips unreadable frames.
    root_all, out = sets
    root = root_all / "culane-png"
    first_map(root, "_1_avg.png").write_bytes(lying_png(8192, 8191))
    result = CliRunner().invoke(main, ["run", "--data-root", str(root / "data"), "--maps-root", str(root / "maps"),
                                       "--maps-format", "scnn-png", "--on-error", "skip", "--workers", "1",
                                       "--quiet", "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert "00000_1_avg.png: not a readable image" in result.output and "(frame skipped)" in result.output


@pytest.mark.parametrize("variable, value", [("RONELD_EVAL_MAX_LANES", "0"), ("RONELD_EVAL_MAX_JSON_MIB", "lots")])
def test_a_bound_set_to_no_number_is_one_line_before_any_work(tmp_path, monkeypatch, variable, value):
    # Said only where the first file of its kind was read: `score` printed its progress bar first,
    # and a TuSimple bound stopped a CULane run never.
    _one_frame_of_1001_lanes(tmp_path)
    monkeypatch.setenv(variable, value)
    commands = [["run", "--out", str(tmp_path / "run")],
                ["score", "culane", "--data-root", str(tmp_path / "gt"), "--pred-root", str(tmp_path / "pred"),
                 "--list", str(tmp_path / "list.txt"), "--out", str(tmp_path / "score")],
                ["synth", "--dataset", "culane", "--out", str(tmp_path / "synth")],
                ["synth", "--dataset", "culane", "--frames", "100", "--clips", "3", "--out", str(tmp_path / "synth")]]
    for args in commands:
        result = CliRunner().invoke(main, args)
        assert result.exit_code == 2 and result.output.startswith(f"error: {variable}={value!r}: give the "), \
            result.output
        assert result.output.count("\n") == 1, result.output
    assert sorted(path.name for path in tmp_path.iterdir()) == ["gt", "list.txt", "pred"]


def test_a_progress_bar_stopped_by_an_error_is_erased_above_its_line(tmp_path, monkeypatch):
    # The error's one line stood under "scoring:   0%|  | 0/1", a bar that would never go on.
    from roneld_eval import progress

    monkeypatch.setattr(progress, "stderr_is_terminal", lambda: True)  # bars are drawn on terminals only
    _one_frame_of_1001_lanes(tmp_path)
    result = CliRunner().invoke(main, ["score", "culane", "--data-root", str(tmp_path / "gt"), "--pred-root",
                                       str(tmp_path / "pred"), "--list", str(tmp_path / "list.txt")])
    assert result.exit_code == 2 and "scoring" in result.output, result.output  # a bar was drawn
    *_, erased, said = result.output.split("\r")
    assert not erased.strip() and said.startswith("error: ") and said.count("\n") == 1, result.output


def test_a_file_given_for_a_folder_is_said_to_be_a_file_not_missing(tmp_path):
    # A first-time user: --maps-root, --pred-root, compare and merge said "not found" of a file that is there.
    made = synth_culane(tmp_path / "set", clips=1, frames=2, seed=1)
    afile = tmp_path / "afile.txt"
    afile.write_text("x")
    for args, said in (
            (["run", "--data-root", str(made.data_root), "--maps-root", str(afile), "--out", str(tmp_path / "o")],
             f"error: {afile}: is a file, not a folder"),
            (["score", "culane", "--data-root", str(made.data_root), "--pred-root", str(afile)],
             f"error: {afile}: is a file, not a folder"),
            (["compare", str(afile), "--out", str(tmp_path / "c")],
             f"error: {afile}: is a file, not a folder: give a folder written by `roneld-eval run`"),
            (["merge", str(afile), "--out", str(tmp_path / "m")],
             f"error: {afile}: is a file, not a folder: give the folder of a shard's part"),
            (["merge", str(tmp_path / "nothere"), "--out", str(tmp_path / "m")],
             f"error: {tmp_path / 'nothere'}: not found: give the folder of a shard's part")):
        done = CliRunner().invoke(main, args)
        assert (done.exit_code, done.output) == (2, said + "\n"), args


def test_a_data_root_one_folder_off_is_pointed_to_the_one_that_reads(tmp_path):
    # A first-time user gave synth's set folder (its data/ holds the dataset): "list file not found", no hint.
    made = synth_culane(tmp_path / "set", clips=1, frames=2, seed=1)
    for given in (tmp_path / "set", made.data_root / "typo"):
        done = CliRunner().invoke(main, ["run", "--data-root", str(given), "--maps-root", str(made.maps_root),
                                         "--out", str(tmp_path / "o")])
        assert done.exit_code == 2 and done.output.count("\n") == 1, done.output
        assert done.output.endswith(f"; did you mean --data-root {made.data_root} (it holds the dataset)?\n")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    done = CliRunner().invoke(main, ["run", "--data-root", str(elsewhere), "--maps-root", str(made.maps_root),
                                     "--out", str(tmp_path / "o")])
    assert done.exit_code == 2 and "did you mean" not in done.output
