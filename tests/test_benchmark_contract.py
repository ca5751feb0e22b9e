"""What every registered benchmark must do, from one parametrised list: a new benchmark gets these
tests by being registered. On its synthetic set: the command `synth` prints runs; two shards of it
merged give its official table byte for byte; and a run's official table is read back by compare."""

from __future__ import annotations

import shlex
from pathlib import Path

import pytest
from click.testing import CliRunner

from roneld_eval import benchmarks
from roneld_eval.cli import main

BUILT_IN = [name for name in benchmarks.names() if benchmarks.origin(name) == "built in"]


def invoke(*args: str) -> str:
    result = CliRunner().invoke(main, list(args), catch_exceptions=False)
    assert result.exit_code == 0, f"{' '.join(args)}\n{result.output}"
    return result.output


def evaluating_command(root: Path, name: str, maps_format: str | None = None) -> list[str]:
    """The command `synth` says evaluates the set it wrote (maps in `maps_format`, else the
    benchmark's own choice), without the program's name."""
    benchmark = benchmarks.benchmark_for(name)
    maps_format = maps_format or getattr(benchmark, "synth_maps_format", "npy")
    result = benchmark.synthesize(root / "set", clips=2, frames=min(benchmark.frames_per_clip, 3), seed=5,
                                  maps_format=maps_format, progress=None)
    argv = shlex.split(result.command)
    assert argv[0] == "roneld-eval"
    return argv[1:] + (["--workers", "1"] if argv[1] == "run" else [])


@pytest.mark.parametrize("name", BUILT_IN)
def test_its_synthetic_set_scores_and_two_shards_merge_into_the_same_table(tmp_path, name):
    command = evaluating_command(tmp_path, name)
    invoke(*command, "--out", str(tmp_path / "whole"))
    whole = (tmp_path / "whole" / "official.csv").read_text()
    assert whole.count("\n") >= 2
    for share in ("1/2", "2/2"):
        invoke(*command, "--shard", share, "--out", str(tmp_path / f"part{share[0]}"))
    invoke("merge", str(tmp_path / "part1"), str(tmp_path / "part2"), "--out", str(tmp_path / "merged"))
    assert (tmp_path / "merged" / "official.csv").read_text() == whole


@pytest.mark.parametrize("name", [name for name in BUILT_IN if benchmarks.benchmark_for(name).default_preset])
def test_a_runs_official_table_is_read_back_by_compare(tmp_path, name):
    from roneld_eval.config import EvalConfig

    preset = EvalConfig.from_toml(benchmarks.benchmark_for(name).default_preset)
    command = evaluating_command(tmp_path, name, preset.maps.format)  # maps its preset's model writes
    assert command[0] == "run"
    for run in ("a", "b"):
        invoke(*command, "--out", str(tmp_path / run), "--set", f"model=Model{run.upper()}")
    invoke("compare", str(tmp_path / "a"), str(tmp_path / "b"), "--out", str(tmp_path / "compared"))
    official = (tmp_path / "compared" / "table_official.md").read_text()
    assert "ModelA" in official and "ModelB" in official
