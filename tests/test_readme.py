"""The README as a newcomer pastes it: its numbers are those in results/, and every roneld-eval
command in its shell blocks parses against the command line as written."""

from __future__ import annotations

import json
import re
import shlex
import warnings

import click
import pytest
from conftest import REPO

from roneld_eval.cli import main

README = (REPO / "README.md").read_text(encoding="utf-8")


def shell_blocks(text: str) -> list[str]:
    return re.findall(r"^```sh\n(.*?)^```", text, flags=re.S | re.M)


def commands(block: str) -> list[list[str]]:
    """The roneld-eval invocations of a shell block, continuation lines joined, as argv lists."""
    joined = block.replace("\\\n", " ")
    found = []
    for line in joined.splitlines():
        line = line.split("  #")[0]  # a comment after the command
        for part in re.split(r"&&|;|\|\|", line):
            words = shlex.split(part)
            for start, word in enumerate(words):
                if word.endswith("roneld-eval"):
                    found.append(words[start + 1:])
                    break
    return found


def table_rows(text: str, header: str) -> list[str]:
    lines = text.splitlines()
    start = lines.index(header)
    rows = []
    for line in lines[start + 2:]:
        if not line.startswith("|"):
            break
        rows.append(line)
    return rows


def test_the_fixture_table_is_results_accuracy_md():
    header = "| IoU threshold | SCNN | SCNN + RONELD | Acc. Inc. | SCNN + RONELD w/o PFT | SCNN + RONELD | Acc. Inc. |"
    committed = (REPO / "results" / "accuracy.md").read_text(encoding="utf-8")
    assert table_rows(README, header) == table_rows(committed, header)


def test_the_fixture_counts_are_results_summary_json():
    counts = json.loads((REPO / "results" / "summary.json").read_text(encoding="utf-8"))["counts"]
    stated = re.search(r"On the fixture's (\d+) clips, (\d+)\s+frames, (\d+) ego lanes", README)
    assert stated is not None
    assert tuple(map(int, stated.groups())) == (counts["clips"], counts["frames"], counts["ego_lanes"])


def _remaining(context: click.Context) -> list[str]:
    with warnings.catch_warnings():  # click 8.2 keeps a group's subcommand in protected_args, 9.0 in args
        warnings.simplefilter("ignore", DeprecationWarning)
        return [*getattr(context, "protected_args", []), *context.args]


def _parse(argv: list[str]) -> None:
    """Parse `roneld-eval ARGV` as click would run it, without running anything."""
    context = main.make_context("roneld-eval", list(argv), resilient_parsing=False)
    command: click.Command = main
    while isinstance(command, click.Group) and _remaining(context):
        name, sub, rest = command.resolve_command(context, _remaining(context))
        assert sub is not None, name
        context = sub.make_context(name, rest, parent=context)
        command = sub


INVOCATIONS = [argv for block in shell_blocks(README) for argv in commands(block)]


def test_the_readme_has_commands_to_check():
    assert len(INVOCATIONS) >= 20
    assert {argv[0] for argv in INVOCATIONS if argv} >= {"run", "score", "compare", "show", "synth"}
    for wrong in (["run", "--no-such-option"], ["score", "culane", "--pred", "x"], ["scor"]):
        with pytest.raises(click.UsageError):
            _parse(wrong)


@pytest.mark.parametrize("argv", INVOCATIONS, ids=[" ".join(argv)[:60] for argv in INVOCATIONS])
def test_every_readme_command_parses(argv):
    try:
        _parse(argv)
    except click.exceptions.Exit:  # --version, --help
        pass
    except click.UsageError as error:
        pytest.fail(f"roneld-eval {' '.join(argv)}: {error.format_message()}")


def test_the_examples_say_how_to_reach_the_command():
    # After the two commands roneld-eval is inside .venv, not on PATH: the README must say so
    # before its first example that calls it bare.
    first_bare = min(README.index(block) for block in shell_blocks(README)
                     if any(line.lstrip().startswith("roneld-eval") for line in block.splitlines()))
    assert "source .venv/bin/activate" in README[:first_bare]


def test_the_submitit_recipe_runs_as_written(tmp_path, monkeypatch):
    # The Python block run with a stand-in for submitit (each array task run here, in order) on a
    # generated set at the block's paths: the same calls, the same merge.
    import sys
    import types

    from roneld_eval.benchmarks.culane.synth import synth_lane_files
    from roneld_eval.benchmarks.culane.score import score_culane

    block = next(b for b in re.findall(r"^```python\n(.*?)^```", README, flags=re.S | re.M) if "submitit" in b)
    gt, pred = synth_lane_files(tmp_path / "set", 90)
    for epoch in (1, 2):
        (tmp_path / "work_dirs" / f"epoch_{epoch}").mkdir(parents=True)
        (tmp_path / "work_dirs" / f"epoch_{epoch}" / "lines").symlink_to(pred)

    class Job:
        def __init__(self, value):
            self.value = value

        def result(self):
            return self.value

    class AutoExecutor:
        def __init__(self, folder):
            self.folder = folder

        def update_parameters(self, **parameters):
            assert parameters["slurm_array_parallelism"] == 8

        def map_array(self, function, values):
            return [Job(function(value)) for value in values]

    monkeypatch.setitem(sys.modules, "submitit", types.SimpleNamespace(AutoExecutor=AutoExecutor))
    monkeypatch.chdir(tmp_path)
    exec(compile(block.replace("/data/CULane", str(gt)), "README.md", "exec"), {})
    score_culane(gt, "work_dirs/epoch_*/lines", iou="0.5:0.95:0.05", out=tmp_path / "whole")
    for name in ("official.csv", "summary.csv", "sweep.csv"):
        assert (tmp_path / "sweep" / name).read_bytes() == (tmp_path / "whole" / name).read_bytes(), name


def test_the_why_is_my_f1_low_walkthrough_prints_what_the_readme_shows(tmp_path, monkeypatch):
    import contextlib
    import io

    from click.testing import CliRunner

    section = README.split("### Why is my F1 low?")[1].split("\n### ")[0]
    blocks = re.findall(r"^```(\w*)\n(.*?)^```", section, flags=re.S | re.M)
    assert [language for language, _ in blocks] == ["sh", "", "python", ""]
    (_, sh), (_, console), (_, python), (_, printed) = blocks
    monkeypatch.chdir(tmp_path)
    outputs = []
    for argv in commands(sh):
        result = CliRunner().invoke(main, argv)
        assert result.exit_code == 0, result.output
        outputs.append(result.output)
    for line in console.splitlines():
        assert line in outputs[1].splitlines(), line  # what `score` says
    assert (tmp_path / "why" / "scores" / "show" / "gallery.png").is_file()
    errors_md = (tmp_path / "why" / "scores" / "errors.md").read_text(encoding="utf-8")
    row = next(line for line in section.splitlines() if line.startswith("| det | all |"))
    assert row == next(line for line in errors_md.splitlines() if line.startswith("| det | all |"))
    said = io.StringIO()
    with contextlib.redirect_stdout(said):
        exec(compile(python, "README.md", "exec"), {})
    assert said.getvalue() == printed
