"""Whole runs: the committed results are reproduced, workers do not change a byte, outputs hold."""

import importlib
import json
import os
import platform
import signal
import sys
import time
import types

import numpy as np
import pandas as pd
import pytest
from conftest import REPO, curving_frames, write_culane_tree

import roneld_eval
from roneld_eval import api
from roneld_eval.config import EvalConfig
from roneld_eval.extract import roneld
from roneld_eval.lanes_io import read_lines_txt
from roneld_eval.metrics.lane_iou_f1 import match_frame


def test_fixture_accuracy_equals_the_committed_results(fixture_run):
    _, out = fixture_run
    committed = (REPO / "results" / "accuracy.csv").read_text()
    assert (out / "accuracy.csv").read_text() == committed, (
        "accuracy on the bundled fixture changed; if on purpose, regenerate results/ with the README's "
        "main command and say why in the commit")


def _refresh_command() -> list[str]:
    """The README's command that refreshes results/, as arguments after `roneld-eval`."""
    import re
    import shlex

    (line,) = re.findall(r"^roneld-eval (run .* --out results)$", (REPO / "README.md").read_text(), re.M)
    return shlex.split(line)


def _files(folder):
    return {str(path.relative_to(folder)): path.read_bytes() for path in sorted(folder.rglob("*")) if path.is_file()}


def test_refreshing_results_changes_nothing(tmp_path):
    # Refreshing results/ used to change four files every time (the timings in runtime.csv/.md,
    # summary.json's wall time, report.html), whatever the code did.
    from click.testing import CliRunner

    from roneld_eval.cli import main

    arguments = _refresh_command()
    assert "--no-timings" in arguments
    arguments[-1] = str(tmp_path / "results")
    result = CliRunner().invoke(main, arguments + ["--quiet"])
    assert result.exit_code == 0, result.output
    committed, written = _files(REPO / "results"), _files(tmp_path / "results")
    assert sorted(written) == sorted(committed)
    versions = json.loads(committed["summary.json"])["versions"]
    here = json.loads(written["summary.json"])["versions"]
    same_libraries = versions == here  # and the same kind of machine
    # untimed: the system and processor kind alone, not the kernel build that differed between machines
    assert here["platform"] == f"{platform.system()}-{platform.machine()}", here["platform"]
    for name, data in written.items():
        if name == "summary.json":
            mine, theirs = json.loads(data), json.loads(committed[name])
            if not same_libraries:  # the libraries and machine it ran on are facts about that run
                mine["versions"], theirs["versions"] = {}, {}
            assert mine == theirs
        elif same_libraries or name.rsplit(".", 1)[-1] in ("csv", "md", "tex", "toml"):
            # Pictures (and report.html, which holds them) are compared where the libraries that
            # drew them are those that drew the committed ones.
            assert data == committed[name], f"results/{name} differs from what the README's refresh writes"


def test_run_writes_every_output(fixture_run):
    result, out = fixture_run
    names = {p.name for p in out.iterdir()}
    assert names >= {"accuracy.csv", "accuracy.md", "accuracy.tex", "accuracy_curve.png", "accuracy_curve.svg",
                     "ablation.md", "ablation.tex", "runtime.csv", "runtime.md", "per_frame.csv", "official.csv",
                     "summary.json", "config.toml", "lanes", "report.html", "categories.csv", "categories.png"}
    # No staging, lock or cache left behind: only the manifest of what the run wrote.
    assert [p.name for p in out.iterdir() if p.name.startswith(".")] == [".roneld-run.json"]
    accuracy = pd.read_csv(out / "accuracy.csv", dtype={"threshold": str})
    assert list(accuracy.columns)[:5] == ["method", "threshold", "n_tp", "n_gt", "accuracy"]
    assert accuracy["threshold"].iloc[:3].tolist() == ["0.30", "0.31", "0.32"]
    assert set(accuracy["method"]) == {"baseline", "roneld", "roneld-nopft"}
    per_frame = pd.read_csv(out / "per_frame.csv")
    assert list(per_frame.columns) == ["frame", "side", "method", "iou"]
    # Every table can be recomputed from per_frame.csv.
    for row in accuracy.itertuples():
        ious = per_frame.loc[per_frame["method"] == row.method, "iou"]
        assert (ious > float(row.threshold)).sum() == row.n_tp and len(ious) == row.n_gt
    summary = json.loads((out / "summary.json").read_text())
    assert summary["counts"]["frames"] == result.counts["frames"] == 40
    assert summary["versions"]["numpy"] == np.__version__
    assert "**(" in (out / "accuracy.md").read_text() and "\\textbf{(" in (out / "accuracy.tex").read_text()
    official = pd.read_csv(out / "official.csv")
    assert list(official.columns) == ["method", "category", "tp", "fp", "fn", "precision", "recall", "f1"]
    assert {"all", "ego"} <= set(official["category"])
    runtime = pd.read_csv(out / "runtime.csv")
    assert set(runtime["method"]) == {"baseline", "roneld", "roneld-nopft", "map loading"}


def test_rerun_from_the_written_config(fixture_run, tmp_path):
    _, out = fixture_run
    again = api.run(EvalConfig.from_toml(out / "config.toml"), tmp_path, progress=False)
    assert (tmp_path / "accuracy.csv").read_text() == (out / "accuracy.csv").read_text()
    assert again.counts["clips"] == 4


def test_saved_lanes_score_like_the_run(fixture_run):
    """The saved .lines.txt give the official tool exactly the numbers in official.csv."""
    result, out = fixture_run
    from roneld_eval.api import read_dataset

    dataset = read_dataset("culane", result.dataset.root)  # with its labels (a run's workers read them)
    official = pd.read_csv(out / "official.csv")
    for method in result.config.methods:
        tp = fp = fn = 0
        for clip in dataset.clips:
            for frame in clip.frames:
                stem = frame.relpath.rsplit(".", 1)[0]
                lanes = read_lines_txt(out / "lanes" / method / f"{stem}.lines.txt")
                outcome = match_frame(frame.lanes, lanes)
                tp += outcome.true_positives(0.5)
                fp += outcome.n_pred - outcome.true_positives(0.5)
                fn += outcome.n_gt - outcome.true_positives(0.5)
        row = official[(official["method"] == method) & (official["category"] == "all")].iloc[0]
        assert (row.tp, row.fp, row.fn) == (tp, fp, fn)


@pytest.mark.parametrize("dataset", ["culane", "tusimple"])
def test_workers_do_not_change_results(dataset, tmp_path):
    config = api.default_config(dataset).with_overrides(pft_ablation=True)
    one = api.run(config.with_overrides(workers=1), tmp_path / "one", progress=False)
    two = api.run(config.with_overrides(workers=2), tmp_path / "two", progress=False)
    for name in ("accuracy.csv", "per_frame.csv", "official.csv"):
        assert (tmp_path / "one" / name).read_bytes() == (tmp_path / "two" / name).read_bytes()
    assert one.counts == two.counts


def test_tusimple_fixture_scores_only_labelled_frames(tmp_path):
    result = api.run(api.default_config("tusimple").with_overrides(save_lanes=True), tmp_path, progress=False)
    assert result.counts["frames"] == 80 and result.counts["labelled_frames"] == 4
    assert list(result.official.columns) == ["method", "accuracy", "fp", "fn", "f1_ufld", "f1_clrnet"]
    lines = (tmp_path / "lanes" / "roneld" / "predictions.json").read_text().splitlines()
    assert len(lines) == 4
    record = json.loads(lines[0])
    assert len(record["h_samples"]) == 56 and all(len(lane) == 56 for lane in record["lanes"])
    # RONELD's runtime covers all 20 frames of each clip; the baseline only scored frames.
    runtime = result.runtime.set_index("method")
    assert runtime.loc["roneld", "frames"] == 80 and runtime.loc["baseline", "frames"] == 4
    # The saved predictions give the official script's numbers.
    from roneld_eval.api import score_tusimple

    (tmp_path / "labels.json").write_text((api.fixture_roots("tusimple")[0] / "test_label.json").read_text())
    score = score_tusimple(tmp_path / "labels.json", tmp_path / "lanes" / "roneld" / "predictions.json")
    row = result.official.set_index("method").loc["roneld"]
    assert (score.accuracy, score.fp, score.fn) == (row.accuracy, row.fp, row.fn)
    assert (score.f1_ufld, score.f1_clrnet) == (row.f1_ufld, row.f1_clrnet)  # the F1 papers print


def test_fixture_official_scores_equal_the_committed_ones(fixture_run):
    """The fixture's official CULane scores equal the regression snapshot results/official.csv."""
    _, out = fixture_run
    assert (out / "official.csv").read_text() == (REPO / "results" / "official.csv").read_text()


def test_tusimple_fixture_matches_its_snapshot(tmp_path):
    """Both protocols on the TuSimple fixture equal the regression snapshot (tests/snapshots/)."""
    from conftest import SNAPSHOTS

    config = api.default_config("tusimple").with_overrides(pft_ablation=True, workers=1)
    api.run(config, tmp_path, progress=False)
    for name in ("accuracy.csv", "official.csv"):
        assert (tmp_path / name).read_text() == (SNAPSHOTS / "fixture_tusimple" / name).read_text(), name


def test_per_frame_rows_are_handed_over_once():
    from roneld_eval.evaluation import FrameOutcome, PerFrameRows

    rows = PerFrameRows()
    rows.add("d/v.MP4/00000.jpg", FrameOutcome("d/v.MP4/00000.jpg", "roneld", {"left": 0.5, "right": float("nan")},
                                               None, ()))  # type: ignore[arg-type]
    table = rows.take_table()
    assert table.values.tolist()[0] == ["d/v.MP4/00000.jpg", "left", "roneld", 0.5]
    assert list(table["side"]) == ["left", "right"] and np.isnan(table["iou"][1])
    assert rows.take_table().empty  # handed over: nothing is left, and nothing half
    rows.add("d/v.MP4/00030.jpg", FrameOutcome("d/v.MP4/00030.jpg", "baseline", {"left": 0.25}, None, ()))  # type: ignore[arg-type]
    assert rows.take_table().values.tolist() == [["d/v.MP4/00030.jpg", "left", "baseline", 0.25]]


def _spline_import_doing(on_look_up, monkeypatch):
    """RONELD's import of scipy's spline as in a process that drew no curve yet, `on_look_up(name)`
    run at each name it looks up in scipy.interpolate; that module is returned."""
    real = importlib.import_module("scipy.interpolate")

    class Watched(types.ModuleType):
        def __getattr__(self, name):
            if not name.startswith("__"):  # the import system's own look-ups pass through
                on_look_up(name)
            return getattr(real, name)

    monkeypatch.setitem(sys.modules, "scipy.interpolate", Watched("scipy.interpolate"))
    monkeypatch.setattr(roneld, "_make_interp_spline", None)
    return real


def test_the_first_curve_splines_import_is_left_out_of_its_frames_time(tmp_path, monkeypatch):
    """RONELD imports scipy's spline at the first curve it draws (not in warm-up: most clips never
    reach curve mode); that one-time import is not the frame's time. Here it is made to take a
    second (two look-ups of 0.5 s), against a few ms a frame."""
    frames = curving_frames()
    relpaths = [f"driver_1/clip/{k:05d}.jpg" for k in range(len(frames))]
    data = write_culane_tree(tmp_path / "data", {relpath: "" for relpath in relpaths})
    for relpath, maps in zip(relpaths, frames):
        (tmp_path / "maps" / "driver_1" / "clip").mkdir(parents=True, exist_ok=True)
        np.save(tmp_path / "maps" / (relpath[:-4] + ".npy"), maps)

    imported = []

    def slowly(name):
        imported.append(name)
        time.sleep(0.5)

    _spline_import_doing(slowly, monkeypatch)
    config = EvalConfig.preset("scnn-culane").with_overrides(**{
        "dataset.data_root": str(data), "maps.root": str(tmp_path / "maps"), "methods": ["roneld"], "workers": 1})
    result = roneld_eval.evaluate(config, progress=False)
    assert set(imported) == {"make_interp_spline"}  # the clip reached curve mode, and imported it then
    runtime = result.runtime.set_index("method")
    assert runtime.loc["roneld", "frames"] == len(frames)
    assert runtime.loc["roneld", "mean_ms"] < 500 / len(frames) / 2, runtime


def test_a_signal_during_the_spline_import_waits_for_it(monkeypatch):
    """Cut by a signal, an extension module's initialisation fails ("ImportError: initialization
    failed", seen in 1 of 40 SIGTERMs of a run in one process) and a module lock may stay taken:
    the interruption waits for the import, then stops the run as anywhere else."""
    looked_up = []

    def interrupted(name):
        os.kill(os.getpid(), signal.SIGINT)  # Ctrl-C in the middle of the import
        for _ in range(1000):  # a Python-level loop, where a signal's handler runs at once
            pass
        looked_up.append(name)

    real = _spline_import_doing(interrupted, monkeypatch)
    with pytest.raises(KeyboardInterrupt):
        roneld._interp_spline()
    assert looked_up and roneld._make_interp_spline is real.make_interp_spline  # the import was done first
