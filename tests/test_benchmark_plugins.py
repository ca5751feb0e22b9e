"""A benchmark is one module behind `roneld_eval.benchmarks.Benchmark`, registered under the
entry-point group `roneld_eval.benchmarks`: the toy benchmark in tests/toy_benchmark, outside
the package and installed as a third party's would be, runs through synth, run, score, compare
and report.html (tests/test_structure.py checks that no code outside a benchmark's folder names it)."""

from __future__ import annotations

import csv
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import env_importing

from roneld_eval import benchmarks

PACKAGE = Path(benchmarks.__file__).parents[2]  # the folder holding roneld_eval
TOY = Path(__file__).parent / "toy_benchmark"


def cli(*args: str, path: Path = TOY, check: bool = True, timeout: float = 300) -> subprocess.CompletedProcess:
    env = env_importing(path)
    done = subprocess.run([sys.executable, "-m", "roneld_eval", *args], capture_output=True, text=True, env=env,
                          timeout=timeout)
    if check:
        assert done.returncode == 0, done.stderr
    return done


@pytest.fixture(scope="module")
def toy_runs(tmp_path_factory):
    root = tmp_path_factory.mktemp("toy")
    cli("synth", "--dataset", "toy", "--out", str(root / "set"), "--clips", "5", "--seed", "3")
    data, maps = root / "set" / "data", root / "set" / "maps"
    for name, model in (("run1", "ToyNet"), ("run2", "Other")):
        cli("run", "--dataset", "toy", "--data-root", str(data), "--maps-root", str(maps), "--pft-ablation",
            "--save-lanes", "--set", f"model={model}", "--out", str(root / name), "--quiet", "--workers", "2")
    return root


def test_the_built_in_benchmarks_register_as_entry_points():
    assert {"culane", "tusimple"} <= set(benchmarks.names())
    assert benchmarks.benchmark_for("culane").display_name == "CULane"
    assert benchmarks.default_name() == "culane"


def test_a_third_party_benchmark_runs_and_scores_as_a_built_in_one(toy_runs):
    with open(toy_runs / "run1" / "official.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert [row["method"] for row in rows] == ["baseline", "roneld", "roneld-nopft"]
    # 5 clips of 6 frames; `clips` is counted by the clip-level hook (end_clip)
    assert {(row["frames"], row["clips"]) for row in rows} == {("30", "5")}
    assert len(list((toy_runs / "run1" / "lanes" / "baseline").rglob("*.lanes.txt"))) == 30
    page = (toy_runs / "run1" / "report.html").read_text()
    assert "ToyNet on ToyLanes" in page and "ToyLanes counts lanes" in page
    predicted = sum(int(row["pred_lanes"]) for row in rows if row["method"] == "baseline")
    scored = cli("score", "toy", "--data-root", str(toy_runs / "set" / "data"),
                 "--pred-root", str(toy_runs / "run1" / "lanes" / "baseline"))
    assert scored.stdout.strip().endswith(f"{predicted} predicted")


def test_a_third_party_benchmark_scores_from_python_as_its_command_does(toy_runs):
    line = ("import roneld_eval, sys; print(roneld_eval.score('toy', sys.argv[1], pred_root=sys.argv[2]))")
    done = subprocess.run([sys.executable, "-c", line, str(toy_runs / "set" / "data"),
                           str(toy_runs / "run1" / "lanes" / "baseline")], capture_output=True, text=True,
                          env=env_importing(TOY), timeout=120)
    assert done.returncode == 0, done.stderr
    scored = cli("score", "toy", "--data-root", str(toy_runs / "set" / "data"),
                 "--pred-root", str(toy_runs / "run1" / "lanes" / "baseline"))
    count = re.fullmatch(r"ToyCount\(frames=(\d+), gt_lanes=(\d+), pred_lanes=(\d+)\)\n", done.stdout)
    assert count is not None, done.stdout
    assert scored.stdout == "{} frames: {} ground-truth lanes, {} predicted\n".format(*count.groups())


def test_the_toy_installed_with_pip_runs_and_scores_as_from_its_folder(toy_runs, tmp_path):
    # The toy as a third party ships it: its own pyproject.toml, installed by pip (no hand-made
    # dist-info on the path), its benchmark found through the entry point pip writes.
    import shutil

    source = shutil.copytree(TOY, tmp_path / "toy-lanes", ignore=shutil.ignore_patterns(
        "*.dist-info", "*.egg-info", "build", "__pycache__"))
    site = tmp_path / "site"
    subprocess.run([sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--no-build-isolation", "--no-index",
                    "--target", str(site), str(source)], check=True, capture_output=True, timeout=300)
    assert sorted(p.name for p in site.glob("*.dist-info")) == ["toy_lanes-0.dist-info"]
    listed = cli("score", "--help", path=site)
    assert "toy" in listed.stdout
    out = tmp_path / "run"
    cli("run", "--dataset", "toy", "--data-root", str(toy_runs / "set" / "data"), "--maps-root",
        str(toy_runs / "set" / "maps"), "--pft-ablation", "--set", "model=ToyNet", "--out", str(out), "--quiet",
        "--workers", "2", path=site)
    assert (out / "official.csv").read_bytes() == (toy_runs / "run1" / "official.csv").read_bytes()


def test_compare_shows_a_third_party_benchmarks_official_table(toy_runs, tmp_path):
    cli("compare", str(toy_runs / "run1"), str(toy_runs / "run2"), "--out", str(tmp_path / "cmp"), "--quiet")
    table = (tmp_path / "cmp" / "table_official.md").read_text()
    assert "## ToyLanes" in table and "| ToyNet + RONELD w/o PFT |" in table and "| Other |" in table


def test_an_official_table_a_benchmark_refuses_stops_compare(toy_runs, tmp_path):
    run = tmp_path / "run"
    subprocess.run(["cp", "-r", str(toy_runs / "run1"), str(run)], check=True)
    text = (run / "official.csv").read_text().replace(",30,117,", ",30,117,", 1)
    lines = text.splitlines()
    fields = lines[1].split(",")
    fields[-1] = "9"  # more clips predicted exactly than there are
    (run / "official.csv").write_text("\n".join([lines[0], ",".join(fields), *lines[2:]]) + "\n")
    done = cli("compare", str(run), "--out", str(tmp_path / "cmp"), check=False)
    assert done.returncode == 2 and done.stderr.strip() == f"error: {run / 'official.csv'}: more exact clips than clips"


def test_a_benchmark_that_cannot_be_loaded_is_one_line(tmp_path):
    info = tmp_path / "broken-0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: broken\nVersion: 0\n")
    (info / "entry_points.txt").write_text("[roneld_eval.benchmarks]\nbroken = no_such_module:BENCHMARK\n")
    done = cli("run", "--dataset", "broken", "--out", str(tmp_path / "out"), path=tmp_path, check=False)
    assert done.returncode == 2
    assert done.stderr.strip() == ("error: benchmark 'broken' (no_such_module:BENCHMARK) cannot be loaded: "
                                   "ModuleNotFoundError: No module named 'no_such_module'")


def _package(root: Path, name: str, value: str, module: str, source: str) -> Path:
    info = root / f"{name}_pkg-0.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {name}-pkg\nVersion: 0\n")
    (info / "entry_points.txt").write_text(f"[roneld_eval.benchmarks]\n{value}\n")
    (root / f"{module}.py").write_text(source)
    return root


@pytest.mark.parametrize("source, problem", [
    ('raise RuntimeError("boom at import")\n', "cannot be loaded: RuntimeError: boom at import"),
    ('class X:\n    name = "bad"\nB = X()\n',
     "lacks display_name, image_size, default_preset, frames_per_clip, fixture, score_command (see "
     "roneld_eval.benchmarks.Benchmark)"),
])
def test_a_broken_benchmark_is_one_line_and_is_listed_with_the_others(tmp_path, source, problem):
    path = _package(tmp_path, "bad", "bad = bad_mod:B", "bad_mod", source)
    listed = cli("score", "--help", path=path)  # from the metadata: its import is never tried
    assert "culane" in listed.stdout and "vil100" in listed.stdout and "bad-pkg 0: bad_mod:B" in listed.stdout
    for args in (["score", "bad", "--help"], ["synth", "--dataset", "bad", "--out", str(tmp_path / "s")]):
        done = cli(*args, path=path, check=False)
        assert done.returncode == 2, args
        assert done.stderr.strip() == f"error: benchmark 'bad' (bad_mod:B) {problem}", args


KIT_HINT = ("it imports roneld-eval's own modules, as benchmarks written before the kit did; a benchmark now "
            "builds on roneld_eval.kit alone")


@pytest.mark.parametrize("imported, problem", [
    # what the toy imported when benchmarks reached into the package's modules (ca5cdc9)
    ("from roneld_eval.lanes_io import format_culane_lines",
     "ImportError: cannot import name 'format_culane_lines' from 'roneld_eval.lanes_io' ({where}): "
     f"{KIT_HINT} (format_culane_lines is kit.format_lines_txt)"),
    ("from roneld_eval.synth import _write_maps",
     f"ImportError: cannot import name '_write_maps' from 'roneld_eval.synth' ({{where}}): {KIT_HINT} "
     "(_write_maps is kit.write_maps)"),
    ("from roneld_eval.metrics.culane_official import GroupCounts",
     f"ModuleNotFoundError: No module named 'roneld_eval.metrics.culane_official': {KIT_HINT} "
     '(README "Your own benchmark")'),
    ("from roneld_eval.kit import format_culane_lines",  # the kit's own names: no older version to blame
     "ImportError: cannot import name 'format_culane_lines' from 'roneld_eval.kit' ({where})"),
])
def test_a_benchmark_written_to_the_protocol_before_the_kit_is_told_what_changed(tmp_path, imported, problem):
    import roneld_eval

    path = _package(tmp_path, "old", "old = old_mod:B", "old_mod", f"{imported}\nB = None\n")
    module = imported.split()[1]
    where = Path(roneld_eval.__file__).parent.joinpath(*module.split(".")[1:])
    where = where.with_suffix(".py") if where.with_suffix(".py").is_file() else where / "__init__.py"
    done = cli("synth", "--dataset", "old", "--out", str(tmp_path / "s"), path=path, check=False)
    assert done.returncode == 2
    assert done.stderr == f"error: benchmark 'old' (old_mod:B) cannot be loaded: {problem.format(where=where)}\n"


def test_a_package_cannot_replace_a_built_in_benchmark(tmp_path):
    source = 'class X:\n    name = "culane"\nB = X()\n'
    path = _package(tmp_path, "shadow", "culane = shadow_mod:B", "shadow_mod", source)
    done = cli("run", "--dry-run", path=path)
    assert "culane" in done.stdout + done.stderr and "tusimple" not in done.stdout
    program = ("from roneld_eval.benchmarks import benchmark_for, default_name; "
               "print(type(benchmark_for('culane')).__module__, default_name())")
    checked = subprocess.run([sys.executable, "-c", program],
                             capture_output=True, text=True, env=dict(os.environ, PYTHONPATH=str(path)), check=True)
    assert checked.stdout.split() == ["roneld_eval.benchmarks.culane.benchmark", "culane"]


# What a command that imports nothing sees of the benchmarks: which of their modules it loaded.
IMPORTED_BENCHMARKS = r"""
import json, sys
from roneld_eval.cli import main
try:
    main(sys.argv[1:])
except SystemExit:
    pass
print(json.dumps(sorted(name for name in sys.modules if name.startswith("roneld_eval.benchmarks.")
                        or name == "late_mod")))
"""


@pytest.mark.parametrize("at_import", ["raise SystemExit(0)", "import os\nos._exit(0)", "import time\ntime.sleep(600)"])
def test_help_lists_the_benchmarks_from_their_metadata_and_imports_none(tmp_path, at_import):
    # `score --help` imported every benchmark to list it: one that exited at import made it print
    # nothing (exit 0), one that slept hung it.
    path = _package(tmp_path, "late", "late = late_mod:B", "late_mod", at_import + "\n")
    for args in (["--help"], ["score", "--help"]):
        done = subprocess.run([sys.executable, "-c", IMPORTED_BENCHMARKS, *args], capture_output=True, text=True,
                              env=env_importing(path), timeout=60)
        assert done.returncode == 0, done.stderr
        *shown, imported = done.stdout.splitlines()
        assert json.loads(imported) == [], args
        assert "Usage: " in shown[0], args
    listed = cli("score", "--help", path=path, timeout=60).stdout
    rows = [line.split(None, 1) for line in listed[listed.index("Commands"):].splitlines()[1:]]
    assert {"culane": "built in", "late": "late-pkg 0: late_mod:B"}.items() <= dict(rows).items()


# ---- a third party's benchmark is a plug-in: its import and its calls are guarded --------------


def _variant(root: Path, name: str, body: str, at_import: str = "") -> Path:
    """A package registering benchmark `name`: the toy one with `body` in its class (and
    `at_import` run as its module is imported), with its own preset."""
    preset = (TOY / "toy_lanes" / "toy.toml").read_text().replace('name = "toy"', f'name = "{name}"')
    (root / f"{name}.toml").parent.mkdir(parents=True, exist_ok=True)
    (root / f"{name}.toml").write_text(preset)
    source = (f"import math, os, signal, sys, time\nsys.path.insert(0, {str(TOY)!r})\nimport toy_lanes\n{at_import}\n"
              f"class T(toy_lanes.ToyBenchmark):\n    name = {name!r}\n"
              f"    default_preset = {str(root / f'{name}.toml')!r}\n{body or '    pass'}\nB = T()\n")
    return _package(root, name, f"{name} = {name}_mod:B", f"{name}_mod", source)


@pytest.mark.parametrize("at_import, problem", [
    ("raise SystemExit(0)", "cannot be loaded: SystemExit: 0"),
    ("os._exit(0)", "cannot be loaded: its process ended while importing it (exit status 0)"),
    ("raise KeyError('no')", "cannot be loaded: KeyError: 'no'"),
])
def test_a_benchmark_that_exits_or_raises_at_import_is_one_line_naming_it(toy_runs, tmp_path, at_import, problem):
    # SystemExit(0) or os._exit(0) at import ended `run` with exit status 0, nothing written, not a word.
    path = _variant(tmp_path / "pkg", "gone", "", at_import)
    out = tmp_path / "out"
    for args in (["run", "--dataset", "gone", "--data-root", str(toy_runs / "set" / "data"), "--maps-root",
                  str(toy_runs / "set" / "maps"), "--out", str(out), "--workers", "1"], ["score", "gone", "--help"]):
        done = cli(*args, path=path, check=False, timeout=60)
        assert done.returncode == 2, (args, done.stderr)
        assert done.stdout == "" and done.stderr == f"error: benchmark 'gone' (gone_mod:B) {problem}\n", args
    assert not out.exists()


def _method(header: str, *lines: str) -> str:
    """A method of the variant's class: its header ("score(self, ...)") and its lines."""
    return f"    def {header}:\n" + "".join(f"        {line}\n" for line in lines)


SCORE = "score(self, prepared, prediction, config)"
PREPARE = "prepare(self, frame, config)"
TALLY = "tally(self, methods, dataset, config)"


def _tally_with(table: str) -> str:
    """tally(): the toy's, whose table() is `table` (over `made`, the toy's own table)."""
    return _method(TALLY, "tally = toy_lanes.ToyTally(methods)", "made = tally.table",
                   f"tally.table = lambda: {table}", "return tally")


@pytest.mark.parametrize("body, problem", [
    (_method(SCORE, "return None"),
     "frame seq00/000.jpg: score() returned NoneType, not an official record (an object with to_json())"),
    (_method(SCORE, "return toy_lanes.ToyRecord(math.nan, 1)"),
     "frame seq00/000.jpg: score() returned a record whose to_json() holds NaN or an infinite number"),
    (_method(SCORE, "return 1 / 0"), "frame seq00/000.jpg: score() raised ZeroDivisionError: division by zero"),
    (_method(SCORE, "sys.exit(0)"), "frame seq00/000.jpg: score() raised SystemExit: 0"),
    # On one frame: with two workers, processes that ended on frames of two clips at once would be
    # named in the order they are found.
    (_method(PREPARE, "self.frame = frame.relpath", "return len(frame.lanes)")
     + _method(SCORE, "if self.frame == 'seq00/001.jpg':", "    os._exit(0)",
               "return toy_lanes.ToyRecord(prepared, len(prediction.lanes))"),
     "frame seq00/001.jpg: its process ended inside the plug-in (exit status 0)"),
    (_method(PREPARE, "if frame.relpath == 'seq00/001.jpg':", "    os.kill(os.getpid(), signal.SIGKILL)",
             "return len(frame.lanes)"),
     "frame seq00/001.jpg: its process ended inside the plug-in (signal 9)"),
    (_tally_with("[[1, 2]]"), "table() returned list, not a pandas DataFrame"),
    (_tally_with("made().drop(columns=['clips'])"), "table() returned a table without its official_columns clips"),
    (_tally_with("made().assign(frames=-1)"),
     "table() returned a table whose column frames holds -1, not a whole number in [0, 2^53]"),
    (_method("lane_file(self, method, frame, lanes)", "return 'lanes'"),
     "frame seq00/000.jpg: lane_file() returned str, not a LaneFile of a name and a text"),
])
@pytest.mark.parametrize("workers", ["1", "2"])
def test_a_benchmark_whose_scoring_fails_stops_the_run_with_one_line(toy_runs, tmp_path, body, problem, workers):
    # Each was a traceback from the cache, the pool or the writer, or (an exit) status 0 without a word.
    path = _variant(tmp_path / "pkg", "flaky", body)
    out = tmp_path / "out"
    done = cli("run", "--dataset", "flaky", "--data-root", str(toy_runs / "set" / "data"), "--maps-root",
               str(toy_runs / "set" / "maps"), "--out", str(out), "--workers", workers, "--quiet", "--save-lanes",
               path=path, check=False, timeout=120)
    assert done.returncode == 2, done.stderr
    said = f", {problem}" if problem.startswith("frame ") else f": {problem}"
    assert done.stderr == f"error: benchmark 'flaky' (flaky_mod:B){said}\n"
    assert not out.exists() or not [p.name for p in out.iterdir()]  # no lock, staging or cache behind


# The command line with short time limits (0.5 s, 0.2 s of grace past it), in a process of its own
# that a hang cannot take with it. (On code without these limits, the test times out.)
SHORT_LIMITS = r"""
import contextlib, sys
with contextlib.suppress(ImportError):
    from roneld_eval.benchmarks import plugins
    from roneld_eval.evaluation import plugin_call, pool
    plugins.BENCHMARK_TIME_LIMIT_S = 0.5
    plugin_call.OVERDUE_GRACE_S = pool.OVERDUE_GRACE_S = 0.2
from roneld_eval.cli import main
main(sys.argv[1:], prog_name="roneld-eval")
"""


# Ignores the alarm, in short sleeps: the worker cannot cut it short, the main process ends it.
DEAF = "signal.signal(signal.SIGALRM, signal.SIG_IGN)"


@pytest.mark.parametrize("at_import, body, problem", [
    ("time.sleep(600)", "", " cannot be loaded: importing it took longer than 0.5 s"),
    (f"{DEAF}\nwhile True:\n    time.sleep(0.01)", "", " cannot be loaded: importing it took longer than 0.5 s"),
    ("", _method(SCORE, "time.sleep(600)"), ", frame seq00/000.jpg: score() took longer than 0.5 s"),
    ("", _method(SCORE, DEAF, "while True:", "    time.sleep(0.01)"), ", frame seq00/000.jpg: took longer than 0.5 s"),
])
@pytest.mark.parametrize("workers", ["1", "2"])
def test_a_benchmark_that_hangs_is_stopped_at_its_time_limit(toy_runs, tmp_path, at_import, body, problem, workers):
    # One that slept at import hung `run` (and `score --help`); one that slept while scoring hung
    # `run --workers 1`: unlike a plug-in method, it had no time limit.
    path = _variant(tmp_path / "pkg", "slow", body, at_import)
    out = tmp_path / "out"
    done = subprocess.run([sys.executable, "-c", SHORT_LIMITS, "run", "--dataset", "slow", "--data-root",
                           str(toy_runs / "set" / "data"), "--maps-root", str(toy_runs / "set" / "maps"), "--out",
                           str(out), "--workers", workers, "--quiet"], capture_output=True, text=True,
                          env=env_importing(path), timeout=60)
    assert done.returncode == 2, done.stderr
    expected = re.escape(f"error: benchmark 'slow' (slow_mod:B){problem}\n")
    if workers == "2":  # two clips start at once: the first frame of either may reach the limit first
        expected = expected.replace("seq00/000", r"seq0[0-9]/000")
    assert re.fullmatch(expected, done.stderr), done.stderr
    assert not out.exists() or not [p.name for p in out.iterdir()]


def test_a_benchmark_whose_score_command_fails_is_one_line(tmp_path):
    path = _variant(tmp_path / "pkg", "nocmd", _method("score_command(self)", "raise SystemExit(3)"))
    done = cli("score", "nocmd", "--help", path=path, check=False, timeout=60)
    assert (done.returncode, done.stdout) == (2, "")
    assert done.stderr == "error: benchmark 'nocmd' (nocmd_mod:B): score_command() raised SystemExit: 3\n"
    path = _variant(tmp_path / "pkg2", "nocmd2", _method("score_command(self)", "return None"))
    done = cli("score", "nocmd2", "--help", path=path, check=False, timeout=60)
    assert (done.returncode, done.stdout) == (2, "")
    assert done.stderr == ("error: benchmark 'nocmd2' has no `score` command: evaluate its maps with "
                           "`roneld-eval run --dataset nocmd2`\n")


def test_a_third_party_benchmark_runs_on_dask_as_here(toy_runs, tmp_path):
    # Its scoring runs in worker processes where it can start them: a Dask worker, daemonic, cannot.
    pytest.importorskip("distributed")
    cli("run", "--dataset", "toy", "--data-root", str(toy_runs / "set" / "data"), "--maps-root",
        str(toy_runs / "set" / "maps"), "--pft-ablation", "--set", "model=ToyNet", "--out", str(tmp_path / "dask"),
        "--quiet", "--workers", "2", "--executor", "dask")
    assert (tmp_path / "dask" / "official.csv").read_bytes() == (toy_runs / "run1" / "official.csv").read_bytes()


def test_the_toy_builds_on_the_kit_alone_and_every_kit_name_resolves():
    """A third party's benchmark imports roneld_eval.kit, nothing else of the package."""
    import ast

    import roneld_eval.kit as kit

    tree = ast.parse((TOY / "toy_lanes" / "__init__.py").read_text(encoding="utf-8"))
    imported = {node.module for node in ast.walk(tree) if isinstance(node, ast.ImportFrom)}
    imported |= {alias.name for node in ast.walk(tree) if isinstance(node, ast.Import) for alias in node.names}
    assert {name for name in imported if name and name.startswith("roneld_eval")} == {"roneld_eval.kit"}
    for name in kit.__all__:
        assert getattr(kit, name) is not None, name


def test_what_a_plug_in_raised_is_one_line_whatever_its_message():
    # An attack pass: a 5 MB message was printed whole, and an exception whose __str__ raises was a traceback.
    from roneld_eval.benchmarks.plugins import import_problem
    from roneld_eval.evaluation.plugin_call import RAISED_TEXT_CHARS, raised_text

    class Unsayable(ImportError):
        def __str__(self):
            raise RuntimeError("no")

    assert raised_text(ValueError("x" * 5_000_000)) == f"ValueError: {'x' * RAISED_TEXT_CHARS} …"
    assert raised_text(ValueError("first\nsecond")) == "ValueError: first"
    assert raised_text(Unsayable(name="roneld_eval.gone")).startswith("Unsayable")
    assert import_problem(Unsayable(name="roneld_eval.gone")).startswith("Unsayable: it imports roneld-eval's own")


def test_a_broken_plug_in_does_not_change_what_a_built_in_run_says(tmp_path):
    # An attack pass: the "maps missing" hint of a built-in run loaded every plug-in, so one raising
    # KeyboardInterrupt at import ended the run as interrupted (one that hung delayed it by 60 s).
    from roneld_eval.benchmarks.culane.synth import synth_culane

    path = _package(tmp_path / "pkg", "ctrlc", "ctrlc = ctrlc_mod:B", "ctrlc_mod", "raise KeyboardInterrupt\n")
    culane = synth_culane(tmp_path / "c", clips=1, frames=2, seed=2, maps_format="lanes")
    empty = tmp_path / "empty"
    empty.mkdir()
    done = cli("run", "--data-root", str(culane.data_root), "--maps-root", str(empty), "--maps-format", "lanes",
               "--workers", "1", "--quiet", "--out", str(tmp_path / "out"), path=path, check=False, timeout=120)
    assert done.returncode == 2, done.stderr
    assert done.stderr.startswith("error: ") and done.stderr.count("\n") == 1 and "ctrlc" not in done.stderr


@pytest.mark.parametrize("name", ["--quiet", "../evil", "a b", "Toy"])
def test_a_benchmark_name_that_cannot_name_a_command_and_folders_is_refused(tmp_path, name):
    path = _package(tmp_path / "pkg", "odd", f"{name} = odd_mod:B", "odd_mod", "B = None\n")
    done = cli("synth", "--dataset", name, "--out", str(tmp_path / "s"), path=path, check=False, timeout=60)
    assert done.returncode == 2
    assert done.stderr == (f"error: benchmark {name!r} (odd_mod:B): a benchmark's name is lowercase letters, digits, "
                           "'-' and '_', beginning with a letter or digit (it names a command and folders)\n")
