"""Any extractor through the same runner: the protocol, plug-ins by entry, and what a broken
plug-in does to a run (one line naming the method, the frame and the problem)."""

from __future__ import annotations

import json
import shutil
import signal
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from conftest import interrupt_after
from test_run_integrity import wait_for

from roneld_eval import api
from roneld_eval.cli import main
from roneld_eval.config import EvalConfig, PluginMethod
from roneld_eval.api import read_dataset
from roneld_eval.resolve import benchmark_named

from roneld_eval.errors import ConfigError, RunInterrupted
from roneld_eval.extract.protocol import Prediction, ego_pair, prediction_problem
from roneld_eval.extract.registry import methods_of, resolve_entry
from roneld_eval.maps import load_maps
from roneld_eval.metrics.lane_iou_f1 import match_frame
from roneld_eval.metrics.paper import ego_masks, side_ious
from roneld_eval.model import Lane
from roneld_eval.benchmarks.culane.synth import synth_culane

CULANE = benchmark_named("culane")


PLUGINS = Path(__file__).with_name("plugin_extractors.py")


def entry(name: str) -> str:
    return f"{PLUGINS}:{name}"


@pytest.fixture(scope="module")
def base(tmp_path_factory):
    root = tmp_path_factory.mktemp("plugins")
    synth_culane(root / "set", clips=5, frames=4, seed=5)
    return root / "set"


@pytest.fixture
def dataset(base, tmp_path):
    shutil.copytree(base, tmp_path / "set")
    return tmp_path / "set"


def run_args(root: Path, out: Path, *extra: str) -> list[str]:
    return ["run", "--data-root", str(root / "data"), "--maps-root", str(root / "maps"), "--quiet",
            "--out", str(out), *extra]


def invoke(args):
    result = CliRunner().invoke(main, args)
    assert "Traceback" not in result.output, result.output
    return result


# ---- a working plug-in is evaluated exactly like the built-in methods -------------------------


def direct_scores(root: Path, config: EvalConfig):
    """The plug-in's IoUs and official matches computed here, without the runner."""
    factory = resolve_entry(entry("ego_points"))
    dataset = read_dataset("culane", root / "data")
    ious, matched = {}, {}
    for clip in dataset.clips:
        extract = factory(config.geometry, {})
        for frame in clip.frames:
            maps = load_maps(root / "maps", frame.relpath, config.maps)
            prediction = extract(maps)
            truth = ego_masks(frame.lanes, config.geometry, config.paper, config.roneld.center_ratio)
            for side, iou in side_ious(truth, prediction.active, config.geometry, config.paper).items():
                ious[(frame.relpath, side)] = iou
            matched[frame.relpath] = match_frame(frame.lanes, list(prediction.lanes)).true_positives(0.5)
    return ious, matched


def test_a_plugin_runs_with_two_workers_and_resume_and_is_in_every_output(dataset, tmp_path, monkeypatch):
    out = tmp_path / "out"
    args = run_args(dataset, out, "--method", f"mine={entry('ego_points')}", "--workers", "2", "--save-lanes",
                    "--overlays", "2")
    result = invoke(args)
    assert result.exit_code == 0, result.output
    accuracy = pd.read_csv(out / "accuracy.csv")
    assert set(accuracy["method"]) == {"baseline", "roneld", "mine"}
    per_frame = pd.read_csv(out / "per_frame.csv")
    official = pd.read_csv(out / "official.csv")
    runtime = pd.read_csv(out / "runtime.csv")
    gains = pd.read_csv(out / "gains.csv")
    assert "mine" in set(official["method"]) and "mine" in set(runtime["method"])
    assert {("mine", "baseline"), ("mine", "roneld")} <= set(zip(gains["method"], gains["reference"]))
    assert len(list((out / "lanes" / "mine").rglob("*.lines.txt"))) == 20
    assert "mine" in (out / "accuracy.md").read_text() and "mine" in (out / "report.html").read_text()
    assert "[methods.mine]" in (out / "config.toml").read_text()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["config"]["methods"]["mine"]["entry"] == entry("ego_points")

    # Its numbers are those of the plug-in called directly and scored with the metrics alone.
    config = api.default_config("culane")
    ious, matched = direct_scores(dataset, config)
    mine = per_frame[per_frame["method"] == "mine"]
    assert len(mine) == len(ious)
    for row in mine.itertuples():
        assert row.iou == pytest.approx(ious[(row.frame, row.side)], rel=1e-9)  # per_frame.csv: 10 digits
    total = official[(official["method"] == "mine") & (official["category"] == "all")]
    assert int(total["tp"].iloc[0]) == sum(matched.values())

    # Resume: an interrupted run's finished clips are reused and give the same bytes.
    again = tmp_path / "again"
    restore = interrupt_after(monkeypatch, 2)
    interrupted = api.default_config("culane").with_overrides(**{
        "dataset.data_root": str(dataset / "data"), "maps.root": str(dataset / "maps"), "workers": 1,
        "save_lanes": True}).with_plugin("mine", entry("ego_points"))
    with pytest.raises(RunInterrupted):
        api.run(interrupted, again, progress=False, overlays=2)
    restore()
    resumed_args = run_args(dataset, again, "--method", f"mine={entry('ego_points')}", "--workers", "2",
                            "--save-lanes", "--overlays", "2", "--resume")
    resumed_args.remove("--quiet")  # the note on what was reused is part of the normal output
    resumed = CliRunner().invoke(main, resumed_args)
    assert resumed.exit_code == 0, resumed.output
    assert "reused 2" in resumed.output
    for name in ("accuracy.csv", "per_frame.csv", "official.csv", "gains.csv"):
        assert (again / name).read_bytes() == (out / name).read_bytes(), name


def test_a_changed_plugin_file_is_not_resumed_from(dataset, tmp_path, monkeypatch):
    plugin = tmp_path / "mine.py"
    plugin.write_text(PLUGINS.read_text())
    config = api.default_config("culane").with_overrides(**{
        "dataset.data_root": str(dataset / "data"), "maps.root": str(dataset / "maps"), "workers": 1,
    }).with_plugin("mine", f"{plugin}:ego_points")
    from roneld_eval.cache import ResultCache

    before = ResultCache(tmp_path / "o", config, CULANE, "v", resume=False).config_key
    assert ResultCache(tmp_path / "o", config, CULANE, "v", resume=True).config_key == before
    plugin.write_text(PLUGINS.read_text() + "\n# a change\n")
    from roneld_eval.extract import registry

    monkeypatch.setattr(registry, "_RESOLVED", {})
    assert ResultCache(tmp_path / "o", config, CULANE, "v", resume=True).config_key != before


def test_a_changed_helper_beside_a_plugin_is_not_resumed_from(dataset, tmp_path, monkeypatch):
    """The plug-in's own modules count, not only its file: here a helper module beside it and a
    package below it, which it imports; a library in a virtual environment beside it does not."""
    import sys

    from roneld_eval.cache import ResultCache
    from roneld_eval.extract import registry

    suffix = tmp_path.name.replace("-", "_")
    home = tmp_path / "code"
    (home / f"pkg_{suffix}").mkdir(parents=True)
    (home / f"pkg_{suffix}" / "__init__.py").write_text("SCALE = 1\n")
    (home / f"helper_{suffix}.py").write_text("OFFSET = 0\n")
    library = home / ".venv" / "lib" / "site-packages" / f"lib_{suffix}.py"
    library.parent.mkdir(parents=True)
    library.write_text("X = 1\n")
    plugin = home / "mine.py"
    plugin.write_text(PLUGINS.read_text() + f"\nimport helper_{suffix}, pkg_{suffix}, lib_{suffix}  # noqa\n")
    monkeypatch.setattr(sys, "path", [*sys.path, str(library.parent)])
    for name in (f"helper_{suffix}", f"pkg_{suffix}", f"lib_{suffix}"):
        monkeypatch.delitem(sys.modules, name, raising=False)  # and gone again afterwards
    config = api.default_config("culane").with_overrides(**{
        "dataset.data_root": str(dataset / "data"), "maps.root": str(dataset / "maps"), "workers": 1,
    }).with_plugin("mine", f"{plugin}:ego_points")

    def key() -> str:
        monkeypatch.setattr(registry, "_RESOLVED", {})
        return ResultCache(tmp_path / "o", config, CULANE, "v", resume=True).config_key

    first = key()
    assert key() == first  # the same code, the same key
    module = sys.modules[registry.resolve_entry(f"{plugin}:ego_points").__module__]
    own = [path.relative_to(home).as_posix() for path in registry.own_modules(module)[1]]
    assert own == ["mine.py", f"helper_{suffix}.py", f"pkg_{suffix}/__init__.py"]
    library.write_text("X = 2\n")
    assert key() == first  # an installed library is not the plug-in's code
    (home / f"helper_{suffix}.py").write_text("OFFSET = 1\n")
    second = key()
    assert second != first
    (home / f"pkg_{suffix}" / "__init__.py").write_text("SCALE = 2\n")
    assert key() not in (first, second)


LATE_PLUGIN = """
import importlib
import sys

from roneld_eval import Lane, Prediction

HELPER = {helper!r}


def make(geometry, params):
    if {where!r} == "factory":
        import {helper}  # noqa: F401

    def extract(maps):
        if {where!r} == "first_frame":
            import {helper}  # noqa: F401
        elif {where!r} == "importlib":
            importlib.import_module(HELPER)
        x = 800 + sys.modules[HELPER].SHIFT
        lane = Lane([[x, 590], [x, 300]])
        return Prediction(lanes=[lane], active=(lane, None))

    return extract
"""


@pytest.mark.parametrize("where", ["factory", "first_frame", "importlib"])
def test_resume_sees_a_helper_the_plugin_imports_only_while_it_runs(dataset, tmp_path, monkeypatch, where):
    # The key hashed the modules loaded when the run started: a helper imported inside make(),
    # on the first frame or through importlib was not in it, and --resume reused stale clips.
    import sys

    from conftest import interrupt_after

    from roneld_eval.errors import RunInterrupted

    helper = f"late_{where}_{tmp_path.name.replace('-', '_')}"
    home = tmp_path / "code"
    home.mkdir()
    (home / f"{helper}.py").write_text("SHIFT = 0\n")
    plugin = home / "late.py"
    plugin.write_text(LATE_PLUGIN.format(helper=helper, where=where))
    monkeypatch.syspath_prepend(str(home))
    config = api.default_config("culane").with_overrides(**{
        "dataset.data_root": str(dataset / "data"), "maps.root": str(dataset / "maps"), "workers": 1,
    }).with_plugin("late", f"{plugin}:make")
    out = tmp_path / "out"
    restore = interrupt_after(monkeypatch, 2)
    with pytest.raises(RunInterrupted, match="2 finished clips kept"):
        api.run(config, out, progress=False)
    restore()
    (home / f"{helper}.py").write_text("SHIFT = 40  # moves every lane\n")
    monkeypatch.delitem(sys.modules, helper, raising=False)
    notes: list[str] = []
    api.run(config, out, progress=False, resume=True, announce=notes.append)
    summary = [n for n in notes if n.startswith("resume:")][0]
    assert "reused 0 finished clips" in summary and "2 plug-in code changed" in summary, summary
    monkeypatch.delitem(sys.modules, helper, raising=False)
    api.run(config, tmp_path / "clean", progress=False)
    for name in ("accuracy.csv", "per_frame.csv", "official.csv"):
        assert (out / name).read_bytes() == (tmp_path / "clean" / name).read_bytes(), name


def test_a_stateful_plugin_sees_every_frame_and_a_stateless_one_only_scored_ones(tmp_path):
    from roneld_eval.benchmarks.tusimple.synth import synth_tusimple

    synth_tusimple(tmp_path / "t", clips=1, frames=20, seed=1)  # only the 20th frame is labelled
    config = api.default_config("tusimple").with_overrides(**{
        "dataset.data_root": str(tmp_path / "t" / "data"), "maps.root": str(tmp_path / "t" / "maps"),
        "workers": 1, "methods": ["baseline"]})
    config = config.with_plugin("counting", f"{PLUGINS}:CountingExtractor").with_plugin("cheap", entry("no_op"))
    result = api.evaluate(config, progress=False)
    frames = result.runtime.set_index("method")["frames"]
    assert frames["counting"] == 20 and frames["cheap"] == 1 and frames["baseline"] == 1


def test_a_plugin_module_is_found_on_the_path_and_in_the_current_directory(tmp_path, monkeypatch):
    (tmp_path / "my_lanes.py").write_text("def make(geometry, params):\n    return lambda maps: None\n")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr("sys.path", [p for p in __import__("sys").path if p not in ("", str(tmp_path))])
    assert callable(resolve_entry("my_lanes:make"))
    with pytest.raises(ConfigError, match="no module named 'not_there'"):
        resolve_entry("not_there:make", "x")
    with pytest.raises(ConfigError, match="has no 'missing'"):
        resolve_entry("my_lanes:missing", "x")


def test_installed_extractors_are_found_by_name(monkeypatch):
    from roneld_eval import plugin_methods

    monkeypatch.setattr(plugin_methods, "installed_extractors", lambda: {"ufld-fix": "pkg.module:make"})
    config = EvalConfig(methods=("baseline", "ufld-fix"))
    assert config.plugins == (PluginMethod("ufld-fix", "pkg.module:make"),)
    # Recorded with its entry, so the written config.toml reruns without the lookup.
    assert 'entry = "pkg.module:make"' in config.to_toml()
    with pytest.raises(ConfigError, match="unknown method 'other'.*ufld-fix"):
        EvalConfig(methods=("other",))


def test_plugin_tables_in_a_config_file(tmp_path):
    text = ('[methods.baseline]\n[methods.roneld]\n[methods.mine]\nentry = "mod:make"\nthreshold = 0.4\n'
            'rows = [1, 2]\ntime_limit_s = 5\n')
    config = EvalConfig.from_toml_text(text)
    assert config.methods == ("baseline", "roneld", "mine")
    assert dict(config.plugins[0].params) == {"threshold": 0.4, "rows": [1, 2]}
    assert config.plugins[0].time_limit_s == 5.0
    assert EvalConfig.from_toml_text(config.to_toml()) == config
    method = methods_of(config)[2]
    assert (method.entry, method.built_in, method.time_limit_s) == ("mod:make", False, 5.0)
    for bad, message in [
        ('[methods.mine]\nthreshold = 1\n', "needs entry"),
        ('[methods.roneld]\nentry = "a:b"\n', "is built in"),
        ('[methods."a/b"]\nentry = "a:b"\n', "bad method name"),
        ('[methods.mine]\nentry = "not an entry"\n', "entry must be"),
        ('[methods.mine]\nentry = "a:b"\nnested = {x = 1}\n', "must be a number, text"),
        ('[methods.mine]\nentry = "a:b"\ntime_limit_s = -1\n', "time_limit_s"),
        ('plugins = []\n', "unknown key 'plugins'"),
    ]:
        with pytest.raises(ConfigError, match=message):
            EvalConfig.from_toml_text(bad)


# ---- a broken plug-in: one line naming the method, the frame and the problem ----------------


BROKEN = [
    ("raises", "raised ZeroDivisionError: division by zero in my post-processing"),
    ("wrong_type", "returned list, not a roneld_eval.Prediction"),
    ("nan_lanes", "lane 1 of 1: has NaN or infinite coordinates"),
    ("far_lanes", r"point \(50000, 300\) lies far outside the 1640x590 image"),
    ("normalised_lanes", "every point lies within 2 px of the image's corner: lanes are in image pixels of the "
                         "1640x590 image, not normalised units"),
    ("one_point_lanes", "lane 1 of 1: has 1 point; a lane needs at least 2"),
    ("factory_raises", "building the extractor raised KeyError: 'threshold'"),
    ("factory_returns_number", "the factory returned int, not a callable extractor"),
    ("exits", "raised SystemExit"),
    ("writes_maps", "raised ValueError: assignment destination is read-only"),
]


@pytest.mark.parametrize("name, problem", BROKEN)
def test_a_broken_plugin_stops_the_run_with_one_line(dataset, tmp_path, name, problem):
    out = tmp_path / "out"
    result = invoke(run_args(dataset, out, "--method", f"bad={entry(name)}", "--workers", "1"))
    assert result.exit_code == 2, result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: method 'bad', frame driver_"), result.output
    import re

    assert re.search(problem, lines[0]), lines[0]
    assert not out.exists() or not (out / "accuracy.csv").exists()


def config_with_methods(path: Path, tables: str) -> Path:
    """The CULane preset as a config file whose methods are the given [methods.NAME] tables."""
    base = api.default_config("culane").to_toml()
    path.write_text(base.replace('methods = ["baseline", "roneld"]\n', "") + "\n" + tables)
    return path


def test_a_plugin_slower_than_its_limit_stops_the_run_in_a_worker_too(dataset, tmp_path):
    config = config_with_methods(tmp_path / "slow.toml", f'[methods.baseline]\n[methods.slow]\n'
                                 f'entry = "{entry("slow_once")}"\ntime_limit_s = 0.5\nseconds = 20\n')
    result = invoke(run_args(dataset, tmp_path / "out", "--config", str(config), "--workers", "2"))
    assert result.exit_code == 2, result.output
    assert "method 'slow', frame " in result.output
    assert "took longer than 0.5 s (time_limit_s in [methods.slow])" in result.output


def timed_run(dataset: Path, out: Path, config: Path, workers: str, within_s: float):
    """`run` with a config file, which must end within `within_s` (a hang is the defect)."""
    import time

    start = time.monotonic()
    result = invoke(run_args(dataset, out, "--config", str(config), "--workers", workers))
    assert time.monotonic() - start < within_s, result.output
    return result


@pytest.mark.parametrize("workers", ["1", "2"])
@pytest.mark.parametrize("how, status, where, says", [
    ("exit", 0, "extract", "exit status 0"), ("exit", 3, "extract", "exit status 3"),
    ("kill", 0, "extract", "signal 9"), ("fork", 0, "extract", "exit status 0"),
    ("exit", 0, "factory", "exit status 0"), ("kill", 0, "factory", "signal 9"),
])
def test_a_plugin_that_ends_its_process_is_an_error_naming_method_and_frame(dataset, tmp_path, workers, how,
                                                                            status, where, says):
    # With --workers 1 the plug-in ran in the main process: os._exit(0) ended the run with exit
    # status 0, no message, and left the lock, staging and cache behind. One that forked first
    # held the pool's pipes open: the run waited out the time limit and blamed it.
    config = config_with_methods(tmp_path / "ends.toml", f'[methods.baseline]\n[methods.ends]\n'
                                 f'entry = "{entry("ends_process")}"\nhow = "{how}"\nstatus = {status}\n'
                                 f'where = "{where}"\n')
    out = tmp_path / "out"
    result = timed_run(dataset, out, config, workers, within_s=15)
    assert result.exit_code == 2, result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1, result.output
    frame = "00030.jpg" if where == "extract" else "00000.jpg"
    assert lines[0].startswith("error: method 'ends', frame ") and lines[0].endswith(
        f"{frame}: its process ended inside the plug-in ({says})"), lines[0]
    assert not out.exists() or not [p.name for p in out.iterdir()]  # no lock, staging or cache behind


@pytest.mark.parametrize("workers", ["1", "2"])
def test_a_plugin_that_ignores_its_alarm_is_stopped_by_the_main_process(dataset, tmp_path, workers, monkeypatch):
    # It escaped time_limit_s: the limit's SIGALRM is delivered inside the worker. The main process
    # gives the alarm a grace to act (2 s) before it kills the worker: here 0.2 s, the same path.
    from roneld_eval.evaluation import pool

    monkeypatch.setattr(pool, "OVERDUE_GRACE_S", 0.2)
    config = config_with_methods(tmp_path / "deaf.toml", f'[methods.baseline]\n[methods.deaf]\n'
                                 f'entry = "{entry("spins_deaf")}"\ntime_limit_s = 0.5\n')
    out = tmp_path / "out"
    result = timed_run(dataset, out, config, workers, within_s=60)
    assert result.exit_code == 2, result.output
    assert result.output.strip().startswith("error: method 'deaf', frame ")
    assert result.output.strip().endswith("00030.jpg: took longer than 0.5 s (time_limit_s in [methods.deaf])")
    assert not out.exists() or not [p.name for p in out.iterdir()]


@pytest.mark.long
def test_ctrl_c_ends_a_run_whose_plugin_swallows_every_signal(dataset, tmp_path):
    # With --workers 1 such a plug-in ran in the main process and the run hung past Ctrl-C.
    import signal
    import subprocess
    import sys
    import time

    spinning = tmp_path / "spinning"
    config = config_with_methods(tmp_path / "deaf.toml", f'[methods.baseline]\n[methods.deaf]\n'
                                 f'entry = "{entry("swallows_everything")}"\ntime_limit_s = 600\n'
                                 f'spinning = "{spinning}"\n')
    out = tmp_path / "out"
    process = subprocess.Popen([sys.executable, "-m", "roneld_eval", *run_args(dataset, out, "--config", str(config),
                                                                          "--workers", "1")],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=tmp_path)
    # Into the spinning frame, however loaded the machine: a fixed 4 s sleep sent Ctrl-C while the
    # command was still starting at load 4, where nothing is running to say what it left.
    wait_for(lambda: spinning.exists() or process.poll() is not None, 120)
    assert spinning.exists(), process.communicate()
    process.send_signal(signal.SIGINT)
    start = time.monotonic()
    _, errors = process.communicate(timeout=60)
    assert time.monotonic() - start < 30
    assert process.returncode == 130, errors
    assert "interrupted: no result was written" in errors.strip().splitlines()[-1], errors
    assert not out.exists() or not [p.name for p in out.iterdir() if p.name != ".roneld-cache"]


def test_on_error_skip_leaves_the_frames_out_for_every_method(dataset, tmp_path):
    out = tmp_path / "out"
    result = invoke(run_args(dataset, out, "--method", f"bad={entry('nan_lanes')}", "--workers", "1",
                             "--on-error", "skip"))
    # The plug-in failed on every frame, so none is scored for anyone: a run that scores
    # nothing is an error, not tables of n/a.
    assert result.exit_code == 2, result.output
    assert "nothing was scored: every labelled frame was skipped (20 skipped, first: method 'bad', frame " \
        in result.output
    assert "NaN or infinite coordinates (frame skipped)" in result.output
    assert not (out / "per_frame.csv").exists()


# ---- the protocol's records -----------------------------------------------------------------


def lane(*points) -> Lane:
    return Lane(np.array(points, np.float64))


def test_a_prediction_keeps_its_active_lanes_among_its_lanes():
    left, right, other = lane((700, 589), (760, 300)), lane((950, 589), (880, 300)), lane((200, 589), (600, 300))
    prediction = Prediction(lanes=[other, left], active=(left, right))
    assert prediction.lanes == (other, left, right)
    assert prediction_problem(prediction, 1640, 590) is None
    assert "active must be (left, right)" in prediction_problem(Prediction(active=(left,)), 1640, 590)
    assert "not a roneld_eval.Lane" in prediction_problem(Prediction(lanes=(np.zeros((2, 2)),)), 1640, 590)
    assert ego_pair([other, left, right], 1640, 590, 0.5) == (left, right)
    assert ego_pair([lane((100, 5))], 1640, 590, 0.5) == (None, None)  # one point: no side


def test_a_plugin_that_defeats_its_alarm_is_still_too_slow(dataset, tmp_path):
    config = config_with_methods(tmp_path / "slow.toml", f'[methods.roneld]\n[methods.stubborn]\n'
                                 f'entry = "{entry("ignores_the_alarm")}"\ntime_limit_s = 0.3\nseconds = 0.4\n')
    result = invoke(run_args(dataset, tmp_path / "out", "--config", str(config), "--workers", "1"))
    assert result.exit_code == 2 and "took longer than 0.3 s" in result.output, result.output


def test_the_same_plugin_name_twice_is_refused(dataset, tmp_path):
    result = invoke(run_args(dataset, tmp_path / "out", "--method", f"m={entry('no_op')}",
                             "--method", f"m={entry('ego_points')}"))
    assert result.exit_code == 2 and "--method m is given twice" in result.output


def test_a_plugin_file_imports_the_modules_beside_it(tmp_path, monkeypatch):
    folder = tmp_path / "mine"
    folder.mkdir()
    (folder / "helpers_for_my_lanes.py").write_text("THRESHOLD = 7\n")
    (folder / "my_lanes.py").write_text("from helpers_for_my_lanes import THRESHOLD\n"
                                        "def make(geometry, params):\n    return lambda maps: THRESHOLD\n")
    monkeypatch.setattr("sys.path", list(__import__("sys").path))
    factory = resolve_entry(f"{folder / 'my_lanes.py'}:make")
    assert factory(None, {})(None) == 7


def test_a_worker_killed_inside_a_call_is_named_before_one_the_pool_terminated(monkeypatch):
    # Two workers inside plug-in calls: one killed itself (SIGKILL), the other was ended by the
    # pool's SIGTERM afterwards; the line named whichever the pool listed first (CI: the second).
    from roneld_eval.plugin_calls import PluginCalls

    calls = {11: ("flaky", "seq02/004.jpg", 0.0), 12: ("flaky", "seq00/001.jpg", 0.0)}
    monkeypatch.setattr(PluginCalls, "open_calls", lambda self: calls)
    tracker = PluginCalls.__new__(PluginCalls)
    assert tracker.died_in({11: -signal.SIGTERM, 12: -signal.SIGKILL}) == ("flaky", "seq00/001.jpg",
                                                                            -signal.SIGKILL)
    assert tracker.died_in({11: -signal.SIGTERM, 12: None})[1] == "seq00/001.jpg"
    assert tracker.died_in({11: 3, 12: -signal.SIGKILL})[1] == "seq02/004.jpg"


def test_a_method_list_written_as_toml_without_quotes_is_told_how_to_write_it():
    # A first-time user's `--set 'methods=[baseline]'` was only "bad method name '[baseline]'".
    from roneld_eval.plugin_methods import check_method_name

    with pytest.raises(ConfigError, match=r"; a list is methods=baseline,roneld or, as TOML, "
                                          r'methods=\["baseline", "roneld"\]$'):
        check_method_name("[baseline]")
    with pytest.raises(ConfigError, match=r"starting with a letter or digit\)$"):
        check_method_name("-x")
