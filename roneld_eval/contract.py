"""What every registered benchmark must do, checked end to end on its own synthetic set: the same
check this package's tests run on each of its benchmarks, and what a third party's benchmark gets
from one line in its tests (through roneld_eval.kit):

    from roneld_eval.kit import check_benchmark

    def test_mine_keeps_the_contract(tmp_path):
        check_benchmark("mine", tmp_path)

The steps, each through the command line a user types: `score NAME --help` builds (where the
benchmark has a score command); the command `synth` prints for a small set runs and writes an
official table; two shards of it merged give that table byte for byte (a run's always; a score
command's where it has --shard; a run's merge reads every clip's frame records back from the parts,
`decode` of `to_json`, and scores nothing again); two
runs of the maps its preset's model writes, their lanes saved (`lane_file`), are read back by
`compare` into one official table; and a run reads the lanes one of them saved as another
detector's (`detector_lanes`, `run --maps-format lanes`). A benchmark that cannot be loaded, lacks a
member or whose score command does not fit its scorer breaks it too. Its `score NAME` is run only
where `synth` prints it (its options are the benchmark's own).
"""

from __future__ import annotations

import shlex
from pathlib import Path
from typing import Any, Sequence

CLIPS, SEED = 2, 5


class ContractBroken(AssertionError):
    """A step of the contract failed: the message names it, the command and what it printed."""


def check_benchmark(name: str, folder: str | Path) -> None:
    """Check the registered benchmark `name` keeps the contract, writing into `folder` (an empty
    folder of the caller's, as pytest's tmp_path); ContractBroken at the first step that fails."""
    from .config import EvalConfig
    from .errors import RoneldEvalError
    from .resolve import benchmark_named

    folder = Path(folder)
    try:  # what is not a command: it loads, has every member, its score command fits its scorer
        benchmark = benchmark_named(name)
        command_built = benchmark.score_command()
        command = _synthesized(benchmark, folder / "set", None)
    except RoneldEvalError as error:
        raise ContractBroken(f"{name}: {error}") from None
    if command_built is not None:
        _invoke("its score command builds", ["score", name, "--help"])
    whole = _official(command, folder / "whole", "its synthetic set is scored")
    if whole.count("\n") < 2:
        raise ContractBroken(f"{name}: its official table has no row:\n{whole}")
    # shards: a run's always; a score command's where it declares them (the built-in ones all do)
    if command[0] == "run" or command_built is not None and any(
            parameter.name == "shard" for parameter in command_built.params):
        for share in ("1/2", "2/2"):
            _invoke(f"shard {share} is scored", [*command, "--shard", share, "--out",
                                                 str(folder / f"part{share[0]}")])
        merged = _official(["merge", str(folder / "part1"), str(folder / "part2")], folder / "merged",
                           "its two shards merge")
        _same(name, "two shards merged", merged, whole)
    if command[0] == "run" and benchmark.default_preset is not None:
        try:
            preset = EvalConfig.from_toml(benchmark.default_preset)
            preset_set = _synthesized(benchmark, folder / "preset-set", preset.maps.format)
        except RoneldEvalError as error:
            raise ContractBroken(f"{name}: {error}") from None
        _compared(name, preset_set, folder, benchmark.detector_lanes is not None)


def _without_maps(command: list[str]) -> list[str]:
    """A run's command without its --maps-root and --maps-format (and their values)."""
    kept: list[str] = []
    skip = False
    for word in command:
        if skip:
            skip = False
        elif word in ("--maps-root", "--maps-format"):
            skip = True
        else:
            kept.append(word)
    return kept


def _synthesized(benchmark: Any, out: Path, maps_format: str | None) -> list[str]:
    """The command `synth` says evaluates a small set it wrote to `out` (maps in `maps_format`, else
    the benchmark's own choice), without the program's name."""
    from .synth import synthesize

    result = synthesize(benchmark, out, clips=CLIPS, frames=min(benchmark.frames_per_clip, 3), seed=SEED,
                        maps_format=maps_format)
    argv = shlex.split(result.command)
    if argv[:1] != ["roneld-eval"] or argv[1:2] not in (["run"], ["score"]):
        raise ContractBroken(f"{benchmark.name}: synth's command is not `roneld-eval run` or `score`: "
                             f"{result.command}")
    if result.dataset != benchmark.name:
        raise ContractBroken(f"{benchmark.name}: its synthesize says its set is of dataset {result.dataset!r}")
    return argv[1:] + (["--workers", "1"] if argv[1] == "run" else [])


def _compared(name: str, command: list[str], folder: Path, reads_lanes: bool) -> None:
    for model in ("ModelA", "ModelB"):
        _invoke(f"a run of {model}", [*command, "--out", str(folder / model), "--set", f"model={model}",
                                      "--save-lanes"])
    if reads_lanes:  # the model's own lanes as another detector's (lane_file, then detector_lanes)
        from .methods import PAPER

        lanes = folder / "ModelA" / "lanes" / PAPER.reference
        _invoke("a run reads the lanes another run saved (run --maps-format lanes)",
                [*_without_maps(command), "--maps-root", str(lanes), "--maps-format", "lanes",
                 "--out", str(folder / "on-lanes")])
    _invoke("compare reads its runs back", ["compare", str(folder / "ModelA"), str(folder / "ModelB"),
                                            "--out", str(folder / "compared")])
    table = folder / "compared" / "table_official.md"
    text = table.read_text(encoding="utf-8") if table.is_file() else f"(no {table})"
    if "ModelA" not in text or "ModelB" not in text:
        raise ContractBroken(f"{name}: compare's official table does not show both runs:\n{text}")


def _official(command: Sequence[str], out: Path, step: str) -> str:
    _invoke(step, [*command, "--out", str(out)])
    table = out / "official.csv"
    if not table.is_file():
        raise ContractBroken(f"{step}: roneld-eval {shlex.join(command)} wrote no official.csv in {out}")
    return table.read_text(encoding="utf-8")


def _same(name: str, what: str, got: str, whole: str) -> None:
    if got != whole:
        raise ContractBroken(f"{name}: {what} give another official table than the whole set's:\n{got}\n"
                             f"the whole set's:\n{whole}")


def _invoke(step: str, args: list[str]) -> str:
    from click.testing import CliRunner

    from .cli import main

    result = CliRunner().invoke(main, args, prog_name="roneld-eval", catch_exceptions=False)
    if result.exit_code == 130:  # Ctrl-C, which the command said as such: it stops the caller too
        raise KeyboardInterrupt
    if result.exit_code != 0:
        raise ContractBroken(f"{step}: roneld-eval {shlex.join(args)} exited {result.exit_code}:\n{result.output}")
    return result.output
