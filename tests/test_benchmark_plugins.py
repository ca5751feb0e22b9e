"""A benchmark is one module behind `roneld_eval.benchmarks.Benchmark`, registered under the
entry-point group `roneld_eval.benchmarks`: the toy benchmark in tests/toy_benchmark, outside
the package and installed as a third party's would be, runs through synth, run, score, compare
and report.html; and no code outside a benchmark's own modules names a benchmark."""

from __future__ import annotations

import ast
import csv
import json
import os
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


def _named_constants(path: Path, names: set[str]) -> list[str]:
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Constant) and isinstance(node.value, str) and node.value in names:
            found.append(f"{path.relative_to(PACKAGE)}:{node.lineno}: {node.value!r}")
    return found


def test_no_code_outside_a_benchmarks_own_modules_names_it():
    """A benchmark's own modules carry its name in their file name (benchmarks/culane_cli.py,
    datasets/culane_synth.py, metrics/culane_official.py); everywhere else a string equal to a
    benchmark's name would be a branch on which benchmark runs."""
    names = {name for name in benchmarks.names()
             if (PACKAGE / "roneld_eval" / "benchmarks" / f"{name}.py").is_file()}
    assert {"culane", "tusimple"} <= names
    found = []
    for path in sorted((PACKAGE / "roneld_eval").rglob("*.py")):
        found += _named_constants(path, {name for name in names if name not in path.name})
    assert found == []


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


def test_a_package_cannot_replace_a_built_in_benchmark(tmp_path):
    source = 'class X:\n    name = "culane"\nB = X()\n'
    path = _package(tmp_path, "shadow", "culane = shadow_mod:B", "shadow_mod", source)
    done = cli("run", "--dry-run", path=path)
    assert "culane" in done.stdout + done.stderr and "tusimple" not in done.stdout
    program = ("from roneld_eval.benchmarks import benchmark_for, default_name; "
               "print(type(benchmark_for('culane')).__module__, default_name())")
    checked = subprocess.run([sys.executable, "-c", program],
                             capture_output=True, text=True, env=dict(os.environ, PYTHONPATH=str(path)), check=True)
    assert checked.stdout.split() == ["roneld_eval.benchmarks.culane", "culane"]


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
