"""Results that cannot lie: a run owns its output folder, commits whole, and resumes only from
clips whose inputs are unchanged.

Each test drives the CLI (or the library where a fault must be injected) on a small generated
dataset and checks what is on disk afterwards, byte for byte.
"""

from __future__ import annotations

import contextlib
import hashlib
import hmac
import json
import os
import pickle
import re
import shutil
import signal
import stat
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from roneld_eval import api, output
from conftest import interrupt_after

from roneld_eval.cli import main
from roneld_eval.errors import InputError, RunInterrupted
from roneld_eval.benchmarks.culane.synth import synth_culane


@pytest.fixture(scope="module")
def base(tmp_path_factory):
    root = tmp_path_factory.mktemp("integrity")
    synth_culane(root / "set", clips=5, frames=3, seed=11)
    return root / "set"


@pytest.fixture
def dataset(base, tmp_path):
    shutil.copytree(base, tmp_path / "set")
    return tmp_path / "set"


def run_args(root: Path, out: Path, *extra: str) -> list[str]:
    return ["run", "--data-root", str(root / "data"), "--maps-root", str(root / "maps"), "--workers", "1",
            "--quiet", "--out", str(out), *extra]


def invoke(args):
    result = CliRunner().invoke(main, args)
    assert "Traceback" not in result.output, result.output
    return result


def snapshot(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def config_for(root: Path, **overrides):
    values = {"dataset.data_root": str(root / "data"), "maps.root": str(root / "maps"), "workers": 1}
    values.update(overrides)
    return api.default_config("culane").with_overrides(**values)


# ---- the output folder belongs to the run ---------------------------------------------------


def test_files_of_an_earlier_run_that_this_run_does_not_write_are_removed(dataset, tmp_path):
    out = tmp_path / "out"
    assert invoke(run_args(dataset, out, "--pft-ablation", "--save-lanes", "--overlays", "1")).exit_code == 0
    assert {"ablation.md", "lanes", "overlays", "overlays.png"} <= {p.name for p in out.iterdir()}
    assert invoke(run_args(dataset, out)).exit_code == 0
    names = {p.name for p in out.iterdir()}
    assert not names & {"ablation.md", "ablation.tex", "lanes", "overlays", "overlays.png"}
    manifest = json.loads((out / output.MANIFEST).read_text())
    assert sorted(manifest["entries"]) == sorted(names - {output.MANIFEST})
    assert not [n for n in names if n.startswith((".staging", ".trash", ".roneld-cache", ".roneld-lock"))]


def test_a_folder_with_foreign_files_is_refused_and_left_alone(dataset, tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "thesis.tex").write_text("my thesis")
    result = invoke(run_args(dataset, out))
    assert result.exit_code == 2
    assert result.output.count("\n") == 1 and "thesis.tex" in result.output and "did not write" in result.output
    assert snapshot(out) == {"thesis.tex": b"my thesis"}


def test_a_run_folder_is_refused_to_another_command(dataset, tmp_path):
    out = tmp_path / "out"
    assert invoke(run_args(dataset, out)).exit_code == 0
    before = snapshot(out)
    result = invoke(["score", "culane", "--data-root", str(dataset / "data"), "--pred-root", str(dataset / "data"),
                     "--out", str(out), "--quiet", "--workers", "1"])
    assert result.exit_code == 2 and "holds the results of `roneld-eval run`" in result.output
    assert snapshot(out) == before


def test_show_writes_into_its_own_folder_and_a_new_run_replaces_it(dataset, tmp_path):
    out = tmp_path / "out"
    assert invoke(run_args(dataset, out, "--overlays", "1")).exit_code == 0
    before = snapshot(out)
    result = invoke(["show", "--run", str(out), "--worst", "2"])
    assert result.exit_code == 0, result.output
    assert (out / "show" / "overlays.png").is_file() and len(list((out / "show" / "overlays").iterdir())) == 2
    after = {k: v for k, v in snapshot(out).items() if not k.startswith("show/")}
    assert after == before  # the run's own pictures and report untouched
    result = invoke(["show", "--run", str(out), "--worst", "1", "--out", str(out)])
    assert result.exit_code == 2 and "own folder" in result.output
    assert invoke(run_args(dataset, out)).exit_code == 0
    assert not (out / "show").exists()  # pictures of the earlier results went with them


def test_a_second_command_into_a_locked_folder_is_refused(dataset, tmp_path):
    out = tmp_path / "out"
    with output.OutputFolder(out, "run"):
        result = invoke(run_args(dataset, out))
        assert result.exit_code == 2 and f"pid {os.getpid()}" in result.output and "another" in result.output
    assert invoke(run_args(dataset, out)).exit_code == 0  # released


def test_a_lock_left_by_a_dead_process_is_taken_over(dataset, tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / output.LOCK).write_text("999999")  # no process holds it
    assert invoke(run_args(dataset, out)).exit_code == 0
    assert not (out / output.LOCK).exists()


def test_leftovers_of_a_killed_run_are_removed(dataset, tmp_path):
    out = tmp_path / "out"
    assert invoke(run_args(dataset, out)).exit_code == 0
    (out / ".staging-x1y2" / "lanes").mkdir(parents=True)
    (out / ".staging-x1y2" / "lanes" / "half.lines.txt").write_text("1 2")
    (out / ".trash-abc").mkdir()
    assert invoke(run_args(dataset, out)).exit_code == 0
    assert not [p for p in out.iterdir() if p.name.startswith((".staging", ".trash"))]


def renames_failing_at(monkeypatch, failing: int) -> list:
    """The output folder's renames, the `failing`-th one refused as a full disk refuses it; the
    sources renamed (or tried), in order."""
    original, calls = os.rename, []

    def rename(source, target):
        calls.append(source)
        if len(calls) == failing:
            raise OSError(28, "No space left on device", str(target))
        return original(source, target)

    monkeypatch.setattr(output.os, "rename", rename)
    return calls


def test_a_failing_move_during_the_commit_leaves_the_old_results(dataset, tmp_path, monkeypatch):
    out = tmp_path / "out"
    assert invoke(run_args(dataset, out, "--pft-ablation")).exit_code == 0
    before = snapshot(out)
    calls = renames_failing_at(monkeypatch, 7)
    result = invoke(run_args(dataset, out, "--thresholds", "0.30:0.40:0.05"))
    assert result.exit_code == 2 and "earlier results are unchanged" in result.output
    assert len(calls) > 7  # the undo ran
    monkeypatch.undo()
    assert snapshot(out) == before
    assert sorted(p.name for p in out.iterdir() if p.name.startswith(".")) == [output.MANIFEST]


def test_a_failing_move_in_a_folder_left_incomplete_keeps_it_marked_incomplete(dataset, tmp_path, monkeypatch):
    out = tmp_path / "out"
    assert invoke(run_args(dataset, out)).exit_code == 0
    (out / output.JOURNAL).write_text(signed({"command": "run", "entries": ["accuracy.csv"], "old": []}))
    renames_failing_at(monkeypatch, 3)
    assert invoke(run_args(dataset, out)).exit_code == 2
    monkeypatch.undo()
    assert (out / output.JOURNAL).exists()  # still incomplete: readers refuse it
    result = invoke(["show", "--run", str(out), "--worst", "1"])
    assert result.exit_code == 2 and "incomplete" in result.output


@pytest.mark.parametrize("number", [signal.SIGINT, signal.SIGTERM, signal.SIGHUP])
def test_a_signal_during_the_commit_is_held_until_it_is_complete(dataset, tmp_path, monkeypatch, number):
    out = tmp_path / "out"
    assert invoke(run_args(dataset, out, "--pft-ablation")).exit_code == 0
    original, calls = os.rename, []

    def interrupted(source, target):
        calls.append(source)
        if len(calls) == 3:
            os.kill(os.getpid(), number)
        return original(source, target)

    monkeypatch.setattr(output.os, "rename", interrupted)
    with pytest.raises(RunInterrupted) as caught:
        api.run(config_for(dataset, **{"paper.thresholds": "0.30:0.40:0.05"}), out, progress=False)
    assert caught.value.exit_code == 128 + number and "complete" in str(caught.value)
    accuracy = (out / "accuracy.csv").read_text()
    assert "0.35" in accuracy and "ablation.md" not in os.listdir(out)  # the new results, whole
    assert not (out / output.CACHE).exists()


def test_a_commit_cut_short_by_a_kill_is_refused_by_readers_and_replaced_by_the_next_run(dataset, tmp_path):
    out = tmp_path / "out"
    assert invoke(run_args(dataset, out, "--pft-ablation")).exit_code == 0
    child = os.fork()
    if child == 0:  # pragma: no cover - runs in the child
        original, calls = os.rename, []

        def killed(source, target):
            calls.append(source)
            if len(calls) == 4:
                os._exit(9)  # as SIGKILL: no cleanup at all
            return original(source, target)

        output.os.rename = killed
        try:
            api.run(config_for(dataset, **{"paper.thresholds": "0.30:0.40:0.05"}), out, progress=False)
        finally:
            os._exit(1)
    _, status = os.waitpid(child, 0)
    assert os.waitstatus_to_exitcode(status) == 9
    assert (out / output.JOURNAL).exists()
    # Half the entries are the old run's, half the killed one's: no reader takes them for results.
    result = invoke(["show", "--run", str(out), "--worst", "1"])
    assert result.exit_code == 2 and "incomplete" in result.output, result.output
    # A command that opens the folder and fails before its commit leaves it as incomplete as it was.
    with pytest.raises(RuntimeError):
        with output.OutputFolder(out, "run"):
            raise RuntimeError("failed before committing")
    assert (out / output.JOURNAL).exists()
    # The next run replaces every entry of both: the old run's ablation.md goes too.
    assert invoke(run_args(dataset, out)).exit_code == 0
    names = set(os.listdir(out))
    assert output.JOURNAL not in names and not [n for n in names if n.startswith((".staging", ".trash"))]
    assert ",0.31," in (out / "accuracy.csv").read_text() and "ablation.md" not in names  # the full sweep
    manifest = json.loads((out / output.MANIFEST).read_text())
    assert sorted(manifest["entries"]) == sorted(names - {output.MANIFEST, output.CACHE})
    assert invoke(["show", "--run", str(out), "--worst", "1"]).exit_code == 0


# ---- resume: only what is still true is reused ----------------------------------------------


def interrupted_run(monkeypatch, root: Path, out: Path, finished: int, **overrides) -> None:
    """A run into `out` stopped (as Ctrl-C) after `finished` clips, leaving them in the cache."""
    restore = interrupt_after(monkeypatch, finished)
    with pytest.raises(RunInterrupted):
        api.run(config_for(root, **overrides), out, progress=False)
    restore()


_CLEAN: dict[str, dict[str, bytes]] = {}


def clean_numbers(root: Path, tmp_path: Path) -> dict[str, bytes]:
    """The numbers of an uninterrupted run on `root` as it is now, run once per content of its
    files: most tests resume the module's set unchanged, and each ran this same run again."""
    digest = hashlib.sha256()
    for path in sorted(root.rglob("*")):
        if path.is_file():
            digest.update(f"{path.relative_to(root)}\0{path.stat().st_size}\0".encode() + path.read_bytes())
    key = digest.hexdigest()
    if key not in _CLEAN:
        clean = tmp_path / "clean"
        shutil.rmtree(clean, ignore_errors=True)
        api.run(config_for(root), clean, progress=False)
        _CLEAN[key] = {name: (clean / name).read_bytes() for name in ("accuracy.csv", "per_frame.csv", "official.csv")}
    return _CLEAN[key]


def resumed(root: Path, out: Path, notes: list[str]) -> dict[str, bytes]:
    api.run(config_for(root), out, progress=False, resume=True, announce=notes.append)
    return {name: (out / name).read_bytes() for name in ("accuracy.csv", "per_frame.csv", "official.csv")}


def first_clip_files(root: Path, pattern: str) -> list[Path]:
    return sorted(sorted(root.rglob("*.MP4"))[0].glob(pattern))


def changed_maps(root: Path) -> None:
    for path in first_clip_files(root / "maps", "*.npy"):
        maps = np.load(path)
        np.save(path, np.ascontiguousarray(maps[[1, 0, 3, 2]]))  # lanes swapped: other numbers


def changed_labels(root: Path) -> None:
    for path in first_clip_files(root / "data", "*.lines.txt"):
        lines = path.read_text().splitlines()
        path.write_text("\n".join(lines[:1]) + "\n")


def dropped_frames(root: Path) -> None:
    listing = root / "data" / "list" / "test.txt"
    lines = listing.read_text().splitlines()
    listing.write_text("\n".join(lines[1:]) + "\n")


@pytest.mark.parametrize("change, reason", [
    (changed_maps, "maps or labels changed"),
    (changed_labels, "maps or labels changed"),
    (dropped_frames, "frame list changed"),
])
def test_resume_recomputes_clips_whose_inputs_changed(dataset, tmp_path, monkeypatch, change, reason):
    out = tmp_path / "out"
    restore = interrupt_after(monkeypatch, 3)
    with pytest.raises(RunInterrupted, match="3 finished clips kept"):
        api.run(config_for(dataset), out, progress=False)
    restore()
    change(dataset)
    notes: list[str] = []
    assert resumed(dataset, out, notes) == clean_numbers(dataset, tmp_path)
    summary = [n for n in notes if n.startswith("resume:")][0]
    assert "reused 2 finished clips" in summary and f"1 {reason}" in summary and "2 not finished" in summary


def test_resume_after_a_configuration_change_recomputes_everything(dataset, tmp_path, monkeypatch):
    out = tmp_path / "out"
    interrupted_run(monkeypatch, dataset, out, 2, **{"paper.gt_thickness_px": 12})
    notes: list[str] = []
    assert resumed(dataset, out, notes) == clean_numbers(dataset, tmp_path)
    assert "reused 0 finished clips" in notes[-1] and "2 configuration or version changed" in notes[-1]
    assert not (out / output.CACHE).exists()


def cache_entries(out: Path) -> list[Path]:
    return sorted((out / output.CACHE).glob("*.json"))


@pytest.mark.parametrize("tamper", [
    pytest.param(lambda p: p.write_text(p.read_text().replace('\\"n_scored\\":3', '\\"n_scored\\":30')), id="edited"),
    pytest.param(lambda p: p.write_text(p.read_text()[:-40]), id="truncated"),
    pytest.param(lambda p: p.write_text("[]"), id="not-an-entry"),
    pytest.param(lambda p: p.write_bytes(b"\xff\xfe garbage"), id="binary"),
    pytest.param(lambda p: (p.unlink(), os.mkfifo(p)), id="fifo"),
    pytest.param(lambda p: (p.unlink(), p.symlink_to("/dev/zero")), id="link-to-dev-zero"),
    pytest.param(lambda p: (p.unlink(), p.mkdir()), id="folder"),
    pytest.param(lambda p: os.truncate(p, 1536 * 2**20), id="huge"),  # read whole before: 1.5 GB
])
def test_an_invalid_cache_entry_is_recomputed_with_a_note(dataset, tmp_path, monkeypatch, tamper):
    out = tmp_path / "out"
    interrupted_run(monkeypatch, dataset, out, 2)
    tamper(cache_entries(out)[0])
    notes: list[str] = []
    assert resumed(dataset, out, notes) == clean_numbers(dataset, tmp_path)
    assert any("cache entry ignored" in n for n in notes) and "1 invalid cache entry" in notes[-1]


def forge(entry: Path, key: bytes) -> None:
    """Rewrite a cache entry with every IoU 1.0, signed with `key`."""
    document = json.loads(entry.read_text())
    body = re.sub(r'"(left|right)":(-?[0-9.e+-]+|"nan")', r'"\1":1.0', document["body"])
    assert body != document["body"]
    entry.write_text(json.dumps({"body": body, "mac": hmac.new(key, body.encode(), hashlib.sha256).hexdigest()}))


def folder_key(path: Path) -> bytes:
    path.unlink()
    path.mkdir()  # os.replace cannot put a key there
    return b""


def trailing_key(path: Path) -> bytes:
    key = bytes.fromhex(path.read_text())
    path.write_text(key.hex() + "\n\n" + "junk" * 10)
    return key


def empty_key(path: Path) -> bytes:
    path.write_bytes(b"")  # a crash between creating the key and writing it
    return b""


def short_key(path: Path) -> bytes:
    path.write_text("00")
    return b"\0"


def shared_key(path: Path) -> bytes:
    path.chmod(0o644)  # another user read it and signs entries with it
    return bytes.fromhex(path.read_text())


def fifo_key(path: Path) -> bytes:
    path.unlink()
    os.mkfifo(path, 0o600)  # must not block the run
    return b""


def zero_key(path: Path) -> bytes:
    path.unlink()
    path.symlink_to("/dev/zero")
    return bytes(32)


@pytest.mark.parametrize("spoil", [empty_key, short_key, shared_key, fifo_key, zero_key, trailing_key])
def test_a_bad_cache_key_is_replaced_and_nothing_signed_with_it_is_reused(dataset, tmp_path, monkeypatch, spoil):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "user-cache"))
    out = tmp_path / "out"
    interrupted_run(monkeypatch, dataset, out, 2)
    key_file = tmp_path / "user-cache" / "roneld-eval" / "cache-key"
    assert stat.S_IMODE(key_file.stat().st_mode) == 0o600
    forged_with = spoil(key_file)
    for entry in cache_entries(out):
        forge(entry, forged_with)
    notes: list[str] = []
    assert resumed(dataset, out, notes) == clean_numbers(dataset, tmp_path)
    assert any(n.startswith(f"note: {key_file}: cache key replaced (") for n in notes), notes
    assert "reused 0 finished clips" in notes[-1]
    assert key_file.is_file() and not key_file.is_symlink() and len(bytes.fromhex(key_file.read_text())) == 32
    assert stat.S_IMODE(key_file.stat().st_mode) == 0o600


def test_a_key_that_cannot_be_replaced_is_said_and_nothing_is_reused(dataset, tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "user-cache"))
    out = tmp_path / "out"
    interrupted_run(monkeypatch, dataset, out, 2)
    key_file = tmp_path / "user-cache" / "roneld-eval" / "cache-key"
    folder_key(key_file)
    notes: list[str] = []
    assert resumed(dataset, out, notes) == clean_numbers(dataset, tmp_path)
    assert any(n.startswith(f"note: {key_file}: the cache key is not a regular file and cannot be replaced")
               for n in notes), notes
    assert "reused 0 finished clips" in notes[-1]


_KEY_RACE = """
import sys
from roneld_eval.secret_key import secret_key
print(secret_key(lambda message: None).hex())
"""


def test_runs_that_create_the_key_at_the_same_moment_share_it(tmp_path):
    # Last writer won: in 196 of 200 trials one of two runs kept a key that was not the file's,
    # and its entries later failed to verify.
    import subprocess
    import sys

    env = {**os.environ, "XDG_CACHE_HOME": str(tmp_path / "user-cache")}
    for attempt in range(3):
        shutil.rmtree(tmp_path / "user-cache", ignore_errors=True)
        processes = [subprocess.Popen([sys.executable, "-c", _KEY_RACE], env=env, stdout=subprocess.PIPE, text=True)
                     for _ in range(6)]
        keys = {process.communicate(timeout=60)[0].strip() for process in processes}
        stored = (tmp_path / "user-cache" / "roneld-eval" / "cache-key").read_text().strip()
        assert keys == {stored}, (attempt, keys, stored)


def test_a_crafted_pickle_in_the_cache_runs_no_code(dataset, tmp_path, monkeypatch):
    out = tmp_path / "out"
    interrupted_run(monkeypatch, dataset, out, 2)
    witness = tmp_path / "pwned"

    class Payload:
        def __reduce__(self):
            return (os.system, (f"touch {witness}",))

    for entry in cache_entries(out):
        entry.write_bytes(pickle.dumps(Payload()))
        entry.with_suffix(".pkl").write_bytes(pickle.dumps(Payload()))
    notes: list[str] = []
    assert resumed(dataset, out, notes) == clean_numbers(dataset, tmp_path)
    assert not witness.exists()


def test_the_cache_holds_plain_json(dataset, tmp_path, monkeypatch):
    out = tmp_path / "out"
    interrupted_run(monkeypatch, dataset, out, 2, save_lanes=True)
    for entry in cache_entries(out):
        document = json.loads(entry.read_text())
        assert set(document) == {"body", "mac"}
        assert json.loads(document["body"])["format"] == "roneld-eval clip cache"


# ---- signals and worker processes -----------------------------------------------------------

SLOW_RUN = """
import sys, time
from roneld_eval import evaluation
original = evaluation.evaluate_clip
def slow(clip, context, *rest):
    time.sleep(0.6)
    return original(clip, context, *rest)
evaluation.one_clip.evaluate_clip = slow  # where the pool calls it
from roneld_eval.cli import main
sys.argv = ["roneld-eval"] + sys.argv[1:]
main()
"""


def start_slow_run(root: Path, out: Path, workers: int):
    import subprocess
    import sys

    args = [sys.executable, "-c", SLOW_RUN, "run", "--data-root", str(root / "data"), "--maps-root",
            str(root / "maps"), "--workers", str(workers), "--quiet", "--out", str(out)]
    return subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def children_of(pid: int) -> list[int]:
    found = []
    for task in Path(f"/proc/{pid}/task").glob("*"):
        with contextlib.suppress(OSError):  # the thread ended meanwhile
            found += [int(x) for x in (task / "children").read_text().split()]
    return found


def process_state(pid: int) -> str | None:
    """The state letter of /proc/PID/stat (R, S, T, Z...), None once the pid is gone."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return None


def alive(pid: int) -> bool:
    return process_state(pid) not in (None, "Z")


def wait_for(condition, timeout: float = 60.0) -> bool:
    import time

    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(0.05)
    return False


needs_proc = pytest.mark.skipif(not Path("/proc/self/task").is_dir(), reason="needs Linux /proc")


@needs_proc
@pytest.mark.parametrize("number", [signal.SIGTERM, signal.SIGHUP, signal.SIGINT])
def test_a_signal_to_the_main_process_ends_the_run_cleanly(dataset, tmp_path, number):
    out = tmp_path / "out"
    process = start_slow_run(dataset, out, workers=2)
    assert wait_for(lambda: len(cache_entries(out)) >= 1 and len(children_of(process.pid)) >= 2)
    workers = children_of(process.pid)
    process.send_signal(number)
    _, errors = process.communicate(timeout=60)
    assert process.returncode == 128 + number, errors
    lines = errors.strip().splitlines()
    assert len(lines) == 1 and "no result was written" in lines[0] and "--resume" in lines[0], errors
    assert wait_for(lambda: not any(alive(pid) for pid in workers), 10)
    assert not [p for p in out.iterdir() if p.name.startswith((".staging", ".trash", ".roneld-lock"))]
    result = invoke(run_args(dataset, out, "--resume"))
    assert result.exit_code == 0, result.output
    assert (out / "accuracy.csv").read_bytes() == clean_numbers(dataset, tmp_path)["accuracy.csv"]


@needs_proc
def test_workers_end_when_the_main_process_is_killed(dataset, tmp_path):
    process = start_slow_run(dataset, tmp_path / "out", workers=2)
    assert wait_for(lambda: len(children_of(process.pid)) >= 2)
    workers = children_of(process.pid)
    process.kill()
    process.communicate(timeout=30)
    assert wait_for(lambda: not any(alive(pid) for pid in workers), 10)


@needs_proc
@pytest.mark.parametrize("number", [signal.SIGINT, signal.SIGTERM])
def test_a_signal_with_a_stopped_worker_still_ends_the_run(dataset, tmp_path, number):
    out = tmp_path / "out"
    process = start_slow_run(dataset, out, workers=2)
    assert wait_for(lambda: len(children_of(process.pid)) >= 2)
    workers = children_of(process.pid)
    os.kill(workers[0], signal.SIGSTOP)
    process.send_signal(number)
    _, errors = process.communicate(timeout=30)
    # The other worker may have finished every clip already: then the signal can land while
    # the results are put in place, and the line says they are complete.
    lines = errors.strip().splitlines()
    assert process.returncode == 128 + number and len(lines) == 1, errors
    assert "no result was written" in lines[0] or "they are complete" in lines[0], errors
    assert wait_for(lambda: not any(alive(pid) for pid in workers), 10)


@needs_proc
def test_a_worker_killed_mid_run_ends_it_with_one_line_and_keeps_finished_clips(dataset, tmp_path):
    out = tmp_path / "out"
    process = start_slow_run(dataset, out, workers=2)
    assert wait_for(lambda: len(cache_entries(out)) >= 1 and len(children_of(process.pid)) >= 2)
    os.kill(children_of(process.pid)[0], signal.SIGKILL)
    _, errors = process.communicate(timeout=60)
    lines = errors.strip().splitlines()
    assert process.returncode == 1 and len(lines) == 1 and "worker process died" in lines[0], errors
    assert "--resume" in lines[0] and cache_entries(out)
    assert invoke(run_args(dataset, out, "--resume")).exit_code == 0
    assert (out / "accuracy.csv").read_bytes() == clean_numbers(dataset, tmp_path)["accuracy.csv"]


# ---- geometry and paths ------------------------------------------------------------------------


def resized_maps(root: Path, width: int, height: int) -> None:
    import cv2

    for path in (root / "maps").rglob("*.npy"):
        maps = np.load(path)
        np.save(path, np.stack([cv2.resize(c, (width, height), interpolation=cv2.INTER_LINEAR) for c in maps]))


def test_the_geometry_really_used_is_printed_and_recorded(dataset, tmp_path):
    resized_maps(dataset, 976, 351)
    out = tmp_path / "out"
    args = run_args(dataset, out)
    args.remove("--quiet")
    result = invoke(args)
    assert result.exit_code == 0, result.output
    assert "maps 976x351" in result.output and "ground truth 20 px, predictions 37 px" in result.output
    geometry = json.loads((out / "summary.json").read_text())["geometry"]
    assert (geometry["map_width"], geometry["map_height"], geometry["rescaled"]) == (976, 351, True)
    assert (geometry["gt_thickness_px"], geometry["pred_thickness_px"]) == (20, 37)
    config = (out / "config.toml").read_text()
    assert "976x351" in config and "20 px" in config  # recorded as a comment


def test_maps_of_another_shape_than_the_preset_says_stop_the_run(dataset, tmp_path):
    resized_maps(dataset, 976, 351)  # whole-frame maps, as SCNN writes them
    out = tmp_path / "out"
    result = invoke(run_args(dataset, out, "--config", "enet-sad-culane"))
    assert result.exit_code == 2, result.output
    line = result.output.strip()
    assert line.count("\n") == 0 and "00000.npy" in line and "976x351" in line and "976x208" in line
    assert "rows 240..589" in line and "crop_top_px=0" in line
    assert not out.exists()


def test_a_run_folder_works_from_any_directory(dataset, tmp_path, monkeypatch):
    monkeypatch.chdir(dataset)
    assert invoke(["run", "--data-root", "data", "--maps-root", "maps", "--workers", "1", "--quiet",
                   "--out", "here"]).exit_code == 0
    config = (dataset / "here" / "config.toml").read_text()
    assert f'data_root = "{dataset / "data"}"' in config
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    result = invoke(["run", "--config", str(dataset / "here" / "config.toml"), "--out", "again", "--quiet"])
    assert result.exit_code == 0, result.output
    assert (elsewhere / "again" / "accuracy.csv").read_bytes() == (dataset / "here" / "accuracy.csv").read_bytes()
    assert invoke(["show", "--run", str(dataset / "here"), "--worst", "1"]).exit_code == 0


def test_a_folder_that_is_not_a_finished_run_is_refused_by_show(dataset, tmp_path):
    folder = tmp_path / "notarun"
    folder.mkdir()
    (folder / "config.toml").write_text("")
    result = invoke(["show", "--run", str(folder)])
    assert result.exit_code == 2 and "not a folder written by `roneld-eval run`" in result.output


def test_open_output_folder_errors_are_one_line(tmp_path):
    target = tmp_path / "file"
    target.write_text("")
    with pytest.raises(InputError, match="not a folder"):
        with output.OutputFolder(target, "run"):
            pass


def test_disk_full_while_plotting_names_the_picture(dataset, tmp_path, monkeypatch):
    import errno

    from PIL import Image

    out = tmp_path / "out"
    assert invoke(run_args(dataset, out)).exit_code == 0
    before = snapshot(out)

    def full(self, path, **kwargs):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(Image.Image, "save", full)  # what writes the PNGs (report/figure_files.py)
    result = invoke(run_args(dataset, out, "--thresholds", "0.30:0.40:0.05"))
    assert result.exit_code == 2 and result.output.count("\n") == 1
    assert "accuracy_curve.png: cannot write: No space left on device" in result.output
    assert snapshot(out) == before


def test_real_png_maps_under_the_wrong_preset_name_a_map_image(real_clip_tree, tmp_path):
    data, maps = real_clip_tree  # the authors' clip: 976x351 maps of the whole frame
    result = invoke(["run", "--config", "enet-sad-culane", "--data-root", str(data), "--maps-root", str(maps),
                     "--maps-format", "scnn-png", "--quiet", "--out", str(tmp_path / "out")])
    assert result.exit_code == 2
    assert "00000_1_avg.png: maps are 976x351" in result.output and "scnn-culane" in result.output


def test_without_pft_the_pictures_are_the_frames_that_differ_most():
    import pandas as pd

    from roneld_eval.report.overlays import worst_frames

    rows = [("a.jpg", "left", "baseline", 0.9), ("a.jpg", "left", "roneld-nopft", 0.9),
            ("b.jpg", "left", "baseline", 0.1), ("b.jpg", "left", "roneld-nopft", 0.8),
            ("c.jpg", "left", "baseline", 0.5), ("c.jpg", "left", "roneld-nopft", 0.6)]
    per_frame = pd.DataFrame(rows, columns=["frame", "side", "method", "iou"])
    assert worst_frames(per_frame, 2) == ["b.jpg", "c.jpg"]
    baseline_only = per_frame[per_frame["method"] == "baseline"]
    assert worst_frames(baseline_only, 2) == ["b.jpg", "c.jpg"]  # one method: its lowest IoUs


def test_a_pft_ablation_without_roneld_is_refused(tmp_path):
    result = invoke(["run", "--methods", "baseline", "--pft-ablation", "--out", str(tmp_path / "o")])
    assert result.exit_code == 2 and "add roneld to the methods" in result.output


# ---- found by an attacker's pass -----------------------------------------------------------


# The journal names only the entries a cut-short commit was replacing and writing (the next
# command replaces them): each must be a plain entry of the folder.
@pytest.mark.parametrize("plan", [
    {"entries": ["../victim"], "old": [], "command": "run"},
    {"entries": [], "old": ["../victim"], "command": "run"},
    {"entries": [], "old": [str(Path("/tmp").resolve())], "command": "run"},
    {"entries": ["."], "old": [], "command": "run"},
    {"entries": [], "old": [".roneld-cache"], "command": "run"},
], ids=["entry-outside", "old-outside", "old-absolute", "entry-dot", "old-own-entry"])
def test_a_forged_journal_touches_nothing(dataset, tmp_path, plan):
    victim = tmp_path / "victim"
    victim.mkdir()
    (victim / "thesis.tex").write_text("mine")
    out = tmp_path / "out"
    out.mkdir()
    (out / output.JOURNAL).write_text(signed(plan))  # even signed with the user's key
    result = invoke(run_args(dataset, out))
    assert result.exit_code == 2 and "cannot be trusted" in result.output
    assert (victim / "thesis.tex").read_text() == "mine" and (out / output.JOURNAL).exists()


def signed(plan: dict) -> str:
    return json.dumps({**plan, "mac": output._journal_mac(plan)})


def test_a_show_killed_in_its_first_commit_inside_a_run_does_not_block_the_next_run(dataset, tmp_path):
    out = tmp_path / "out"
    assert invoke(run_args(dataset, out)).exit_code == 0
    show = out / "show"
    show.mkdir()
    (show / "worst.png").write_bytes(b"half")
    (show / output.JOURNAL).write_text(signed({"command": "show", "entries": ["worst.png"], "old": []}))
    result = invoke(["show", "--run", str(out), "--worst", "1"])
    assert result.exit_code == 0, result.output  # show finishes what it began
    (show / output.MANIFEST).unlink()
    (show / output.JOURNAL).write_text(signed({"command": "show", "entries": ["worst.png"], "old": []}))
    assert invoke(run_args(dataset, out)).exit_code == 0  # was: "holds files roneld-eval did not write (show)"
    assert not show.exists()


def test_a_journal_not_signed_with_the_users_key_names_nothing_the_run_removes(dataset, tmp_path):
    # Names in a journal are what the next command replaces: an unsigned one made a run delete
    # a file of the user's beside the results.
    out = tmp_path / "out"
    assert invoke(run_args(dataset, out)).exit_code == 0
    (out / "mydata.txt").write_text("precious")
    for forged in ({"command": "run", "entries": [], "old": ["mydata.txt"]},
                   {"command": "run", "entries": [], "old": ["mydata.txt"], "mac": "0" * 64}):
        (out / output.JOURNAL).write_text(json.dumps(forged))
        result = invoke(run_args(dataset, out))
        assert result.exit_code == 2 and "not signed with this user's key" in result.output, result.output
        assert (out / "mydata.txt").read_text() == "precious"


def test_a_journal_in_a_folder_with_foreign_files_is_not_acted_on(dataset, tmp_path):
    out = tmp_path / "out"
    (out / ".staging-drafts").mkdir(parents=True)
    (out / ".staging-drafts" / "ch1.tex").write_text("draft")
    (out / "thesis.tex").write_text("mine")
    (out / output.JOURNAL).write_text(signed({"entries": ["ch1.tex"], "old": [], "command": "run"}))
    result = invoke(run_args(dataset, out))
    assert result.exit_code == 2 and "thesis.tex" in result.output
    assert (out / ".staging-drafts" / "ch1.tex").read_text() == "draft" and not (out / "ch1.tex").exists()


def test_staging_named_folders_in_a_foreign_folder_are_left_alone(dataset, tmp_path):
    out = tmp_path / "out"
    (out / ".staging-drafts").mkdir(parents=True)
    (out / ".staging-drafts" / "ch1.tex").write_text("draft")
    (out / "thesis.tex").write_text("mine")
    assert invoke(run_args(dataset, out)).exit_code == 2
    assert (out / ".staging-drafts" / "ch1.tex").read_text() == "draft"


@pytest.mark.parametrize("name", [output.MANIFEST, output.JOURNAL])
def test_a_deeply_nested_record_is_one_line(dataset, tmp_path, name):
    out = tmp_path / "out"
    out.mkdir()
    (out / name).write_text("[" * 100000)
    result = invoke(run_args(dataset, out))
    assert result.exit_code == 2 and result.output.count("\n") == 1 and name in result.output


@pytest.mark.parametrize("left", ["journal", "dangling link", "first commit"])
def test_show_refuses_a_run_whose_commit_was_cut_short(dataset, tmp_path, left):
    out = tmp_path / "out"
    assert invoke(run_args(dataset, out)).exit_code == 0
    if left == "dangling link":
        (out / output.JOURNAL).symlink_to(tmp_path / "nowhere")
    else:
        (out / output.JOURNAL).write_text("{}")
    if left == "first commit":  # killed before any manifest was written
        (out / output.MANIFEST).unlink()
    result = invoke(["show", "--run", str(out), "--worst", "1"])
    assert result.exit_code == 2 and "incomplete" in result.output, result.output


def test_a_label_edited_with_its_old_mtime_is_still_seen(dataset, tmp_path, monkeypatch):
    out = tmp_path / "out"
    interrupted_run(monkeypatch, dataset, out, 3)
    for path in first_clip_files(dataset / "data", "*.lines.txt"):
        info = path.stat()
        text = path.read_text()
        path.write_text("".join(reversed(text.splitlines(keepends=True))))  # same size, other bytes
        os.utime(path, ns=(info.st_atime_ns, info.st_mtime_ns))
    notes: list[str] = []
    assert resumed(dataset, out, notes) == clean_numbers(dataset, tmp_path)
    assert "1 maps or labels changed" in notes[-1]


def test_a_signal_just_after_the_commit_says_the_results_are_complete(dataset, tmp_path, monkeypatch):
    from roneld_eval import cache

    out = tmp_path / "out"
    original = cache.ResultCache.discard
    calls = []

    def interrupted(self):
        calls.append(1)
        if len(calls) == 2:  # the first discard starts the run afresh; the second follows the commit
            os.kill(os.getpid(), signal.SIGTERM)
        return original(self)

    monkeypatch.setattr(cache.ResultCache, "discard", interrupted)
    with pytest.raises(RunInterrupted) as caught:
        api.run(config_for(dataset), out, progress=False)
    assert caught.value.exit_code == 128 + signal.SIGTERM and "complete" in str(caught.value)
    assert (out / "accuracy.csv").is_file() and not (out / output.CACHE).exists()


def test_a_symlinked_cache_folder_is_not_written_through(dataset, tmp_path, monkeypatch):
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (elsewhere / "keep.txt").write_text("keep")
    out = tmp_path / "out"
    out.mkdir()
    (out / output.CACHE).symlink_to(elsewhere)
    interrupted_run(monkeypatch, dataset, out, 2)
    assert sorted(p.name for p in elsewhere.iterdir()) == ["keep.txt"]
    assert not (out / output.CACHE).is_symlink() and cache_entries(out)


class _OddOSError(OSError):
    """An OSError whose constructor takes other arguments than OSError's."""

    def __init__(self, message: str, path: str):
        super().__init__(28, message, path)


@pytest.mark.parametrize("raised", [
    lambda staged: InputError(staged, "cannot write: No space left on device"),
    lambda staged: _OddOSError("No space left on device", str(staged)),
    lambda staged: OSError(28, "No space left on device", str(staged), None, "/elsewhere"),
])
def test_an_error_about_a_staged_file_names_its_place_in_the_output_folder(tmp_path, raised):
    out = tmp_path / "out"
    with pytest.raises((InputError, OSError)) as caught:
        with output.OutputFolder(out, "run") as folder:
            raise raised(folder.staging() / "sub" / "figure.png")
    error = caught.value
    where = error.path if isinstance(error, InputError) else error.filename
    assert where == str(out / "sub" / "figure.png")
    assert "No space left on device" in str(error) and ".staging-" not in str(error)
    if isinstance(error, OSError) and not isinstance(error, InputError):
        assert error.errno == 28 and error.filename2 in (None, "/elsewhere")


def test_an_error_about_another_file_is_left_as_it_is(tmp_path):
    with pytest.raises(OSError) as caught:
        with output.OutputFolder(tmp_path / "out", "run"):
            raise OSError(28, "No space left on device", "/somewhere/else")
    assert caught.value.filename == "/somewhere/else"


def test_a_full_disk_while_writing_the_commit_journal_leaves_the_earlier_results(tmp_path, monkeypatch):
    out = tmp_path / "out"
    with output.OutputFolder(out, "run") as folder:
        (folder.staging() / "accuracy.csv").write_text("earlier\n")
        folder.commit()
    before = sorted(path.name for path in out.iterdir())

    def full(descriptor):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(output.os, "fsync", full)
    with pytest.raises(InputError) as caught:
        with output.OutputFolder(out, "run") as folder:
            (folder.staging() / "accuracy.csv").write_text("later\n")
            folder.commit()
    assert str(caught.value) == f"{out}: cannot write results here: No space left on device"
    assert sorted(path.name for path in out.iterdir()) == before  # no journal, .tmp or trash left
    assert (out / "accuracy.csv").read_text() == "earlier\n"


@pytest.mark.parametrize("earlier", [True, False])
def test_a_full_disk_while_taking_the_lock_names_it_and_leaves_no_lock(tmp_path, monkeypatch, earlier):
    # It said "error: [Errno 28] No space left on device", naming no file, and left an empty lock.
    out = tmp_path / "out"
    if earlier:
        with output.OutputFolder(out, "run") as folder:
            (folder.staging() / "accuracy.csv").write_text("earlier\n")
            folder.commit()
    before = sorted(path.name for path in out.iterdir()) if earlier else None

    def full(descriptor, data):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(output.os, "write", full)
    with pytest.raises(InputError) as caught:
        with output.OutputFolder(out, "run"):
            pass
    monkeypatch.undo()
    assert str(caught.value) == f"{out / output.LOCK}: cannot write: No space left on device"
    if earlier:
        assert sorted(path.name for path in out.iterdir()) == before  # no lock left
        assert (out / "accuracy.csv").read_text() == "earlier\n"
    else:
        assert not out.exists()  # the folder this command made, removed again


_SYNTH_KILLED_IN_ITS_COMMIT = """
import os, signal, sys
from roneld_eval import output
from roneld_eval.cli import main
original, calls = os.rename, []

def rename(source, target):
    calls.append(source)
    if len(calls) == 3:  # data/ of the new set is in place, maps/ still the old set's
        os.kill(os.getpid(), signal.SIGKILL)
    return original(source, target)

output.os.rename = rename
main(["synth", "--dataset", "culane", "--clips", "2", "--frames", "3", "--seed", "1", "--out", sys.argv[1]])
"""


def test_a_run_refuses_a_data_or_maps_root_inside_a_folder_whose_commit_was_cut_short(tmp_path):
    # A synth killed in its commit left the new set's data/ beside the old set's maps/, and a run
    # on them scored without a word: SCNN 0.167 where either set gives 1.000.
    cut = tmp_path / "cut"
    assert invoke(["synth", "--dataset", "culane", "--clips", "2", "--frames", "3", "--out", str(cut)]).exit_code == 0
    killed = subprocess.run([sys.executable, "-c", _SYNTH_KILLED_IN_ITS_COMMIT, str(cut)], capture_output=True,
                            text=True, timeout=300)
    assert killed.returncode == -signal.SIGKILL, killed.stderr
    assert (cut / output.JOURNAL).exists()
    for extra in ([], ["--dry-run"]):
        result = invoke(["run", "--data-root", str(cut / "data"), "--maps-root", str(cut / "maps"), "--workers", "1",
                         "--quiet", "--out", str(tmp_path / "out"), *extra])
        assert result.exit_code == 2 and result.output.count("\n") == 1, result.output
        assert f"{cut}: its content is incomplete (a command was killed while putting it in place)" in result.output
    assert not (tmp_path / "out").exists()
    # the next synth into the folder puts it right, and the run goes on
    assert invoke(["synth", "--dataset", "culane", "--clips", "2", "--frames", "3", "--out", str(cut)]).exit_code == 0
    assert invoke(["run", "--data-root", str(cut / "data"), "--maps-root", str(cut / "maps"), "--workers", "1",
                   "--quiet", "--out", str(tmp_path / "out")]).exit_code == 0


def test_score_refuses_inputs_inside_a_folder_whose_commit_was_cut_short(tmp_path):
    # `run` refused to read such a folder (part old, part new); `score` read it without a word,
    # e.g. the lanes of a `run --save-lanes` killed while putting its folder in place.
    cut = tmp_path / "cut"
    assert invoke(["synth", "--dataset", "culane", "--maps-format", "lanes", "--clips", "2", "--frames", "3",
                   "--out", str(cut)]).exit_code == 0
    shutil.copytree(cut / "data", tmp_path / "data")
    shutil.copytree(cut / "maps", tmp_path / "lanes")
    sound = ["--data-root", str(tmp_path / "data"), "--pred-root", str(tmp_path / "lanes")]
    assert invoke(["score", "culane", *sound, "--quiet"]).exit_code == 0
    (cut / output.JOURNAL).write_text("{}")  # what a commit killed half-way leaves
    for args in (["--data-root", str(cut / "data"), "--pred-root", str(tmp_path / "lanes")],
                 ["--data-root", str(tmp_path / "data"), "--pred-root", f"mine={cut / 'maps'}"]):
        result = invoke(["score", "culane", *args, "--quiet", "--out", str(tmp_path / "out")])
        assert result.exit_code == 2 and result.output.count("\n") == 1, result.output
        assert f"{cut}: its content is incomplete (a command was killed while putting it in place)" in result.output
        assert not (tmp_path / "out").exists()
    (tmp_path / "link").symlink_to(cut / "maps")  # reached through a link
    result = invoke(["score", "culane", "--data-root", str(tmp_path / "data"), "--pred-root", str(tmp_path / "link"),
                     "--quiet"])
    assert result.exit_code == 2 and f"{cut}: its content is incomplete" in result.output, result.output
    shutil.copy(tmp_path / "data" / "list" / "test.txt", cut / "test.txt")  # run's --list
    result = invoke(["run", "--data-root", str(tmp_path / "data"), "--maps-root", str(tmp_path / "lanes"),
                     "--maps-format", "lanes", "--list", str(cut / "test.txt"), "--workers", "1", "--quiet", "--out",
                     str(tmp_path / "out")])
    assert result.exit_code == 2 and f"{cut}: its content is incomplete" in result.output, result.output
    tusimple = tmp_path / "ts"
    assert invoke(["synth", "--dataset", "tusimple", "--maps-format", "lanes", "--clips", "2", "--out",
                   str(tusimple)]).exit_code == 0
    (tusimple / output.JOURNAL).write_text("{}")
    result = invoke(["score", "tusimple", "--labels", str(tusimple / "data" / "test_label.json"), "--pred",
                     str(tusimple / "maps" / "predictions.json")])
    assert result.exit_code == 2 and f"{tusimple}: its content is incomplete" in result.output, result.output


def test_files_put_inside_a_folder_a_command_wrote_are_not_replaced_with_it(tmp_path):
    # A second synth replaced its maps/ whole, with a run the user had written into maps/run1.
    made = tmp_path / "set"
    synth = ["synth", "--dataset", "culane", "--clips", "2", "--frames", "3", "--out", str(made)]
    assert invoke(synth).exit_code == 0
    assert invoke(synth).exit_code == 0  # its own set, as it wrote it: replaced
    assert invoke(["run", "--data-root", str(made / "data"), "--maps-root", str(made / "maps"), "--workers", "1",
                   "--quiet", "--out", str(made / "maps" / "run1")]).exit_code == 0
    (made / "data" / "notes.txt").write_text("mine")
    result = invoke(synth)
    assert result.exit_code == 2 and result.output.count("\n") == 1, result.output
    assert f"{made / 'data'}: its files changed since `roneld-eval synth` wrote them" in result.output
    assert (made / "maps" / "run1" / "accuracy.csv").is_file() and (made / "data" / "notes.txt").is_file()
    (made / "data" / "notes.txt").unlink()
    result = invoke(synth)
    assert result.exit_code == 2 and f"{made / 'maps'}: its files changed" in result.output, result.output
    shutil.rmtree(made / "maps" / "run1")
    (made / "maps" / ".DS_Store").write_bytes(b"\0")  # a file browser's, not the user's
    assert invoke(synth).exit_code == 0
    # A run's show/ (a nested command's folder) goes with the run that replaces it, not with files put in it.
    run = ["run", "--data-root", str(made / "data"), "--maps-root", str(made / "maps"), "--workers", "1", "--quiet",
           "--out", str(tmp_path / "run")]
    assert invoke(run).exit_code == 0
    assert invoke(["show", "--run", str(tmp_path / "run")]).exit_code == 0
    (tmp_path / "run" / "show" / "my_notes.txt").write_text("mine")
    result = invoke(run)
    assert result.exit_code == 2 and f"{tmp_path / 'run' / 'show'}: holds files roneld-eval did not write " \
                                     "(my_notes.txt)" in result.output, result.output
    assert (tmp_path / "run" / "show" / "my_notes.txt").is_file()
    (tmp_path / "run" / "show" / "my_notes.txt").unlink()
    assert invoke(run).exit_code == 0


def test_a_users_folder_named_like_a_leftover_is_foreign_where_the_tool_never_wrote(tmp_path):
    # `.staging-mine` in a folder with no manifest, journal or lock was taken for a killed
    # command's staging and deleted with the user's file in it.
    folder = tmp_path / "u"
    (folder / ".staging-mine").mkdir(parents=True)
    (folder / ".staging-mine" / "important").write_text("precious")
    result = invoke(["synth", "--dataset", "culane", "--clips", "1", "--frames", "2", "--out", str(folder)])
    assert result.exit_code == 2 and "holds files roneld-eval did not write (.staging-mine)" in result.output
    assert sorted(p.name for p in folder.iterdir()) == [".staging-mine"]
    assert (folder / ".staging-mine" / "important").read_text() == "precious"


@pytest.mark.parametrize("number", [signal.SIGINT, signal.SIGTERM, signal.SIGHUP])
def test_a_signal_between_the_commit_and_the_folders_end_says_the_results_are_complete(tmp_path, number):
    # It went on as an interruption of the work ("no result was written"), the results in place.
    from roneld_eval.signals import terminate_as_interrupt

    out = tmp_path / "out"
    with pytest.raises(BaseException) as caught, terminate_as_interrupt():  # a Ctrl-C must not stop pytest
        with output.OutputFolder(out, "run") as folder:
            (folder.staging() / "accuracy.csv").write_text("new\n")
            folder.commit()
            os.kill(os.getpid(), number)
    assert isinstance(caught.value, RunInterrupted), repr(caught.value)
    assert caught.value.exit_code == 128 + number and "they are complete" in str(caught.value)
    assert signal.Signals(number).name in str(caught.value)
    assert sorted(path.name for path in out.iterdir()) == [output.MANIFEST, "accuracy.csv"]  # no lock


@pytest.mark.parametrize("made", ["lock", "staging"])
def test_a_signal_while_the_lock_or_the_staging_folder_is_made_leaves_neither(tmp_path, monkeypatch, made):
    # Between the lock file's creation and the descriptor kept to release it (or mkdtemp and the
    # staging folder's name kept), a signal left the file or the folder behind (1 of 500 tries).
    from roneld_eval.signals import Terminated, terminate_as_interrupt

    out = tmp_path / "out"
    with output.OutputFolder(out, "run") as folder:
        (folder.staging() / "accuracy.csv").write_text("earlier\n")
        folder.commit()
    module, name = (output.fcntl, "flock") if made == "lock" else (output.tempfile, "mkdtemp")
    original = getattr(module, name)

    def signalled(*args, **kwargs):
        done = original(*args, **kwargs)
        os.kill(os.getpid(), signal.SIGTERM)
        return done

    monkeypatch.setattr(module, name, signalled)
    with pytest.raises(BaseException) as caught, terminate_as_interrupt():
        with output.OutputFolder(out, "run") as folder:
            folder.staging()
    monkeypatch.undo()
    assert isinstance(caught.value, Terminated), repr(caught.value)
    assert sorted(path.name for path in out.iterdir()) == [output.MANIFEST, "accuracy.csv"]
