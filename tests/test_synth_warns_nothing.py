"""What `synth --dataset NAME` writes is a clean set: the command it prints, and the benchmark's
`score` on the same lanes, run without a warning, so that a warning met on it says something about
the change under test, not about the fixture (synth --dataset vil100 wrote ground truth past every
video's size, and `score vil100` asked of each of its sequences "is the size right?")."""

from __future__ import annotations

import shlex
from pathlib import Path

import pytest
from click.testing import CliRunner

from roneld_eval.cli import main
from roneld_eval.benchmarks.vil100.synth import SIZES

# each benchmark's smallest set that still covers what it varies (VIL-100: every one of its sizes)
SETS = {"culane": ("--clips", "2", "--frames", "3"), "tusimple": ("--clips", "2"),
        "vil100": ("--clips", str(len(SIZES)), "--frames", "2"), "openlane": ("--clips", "2"),
        "curvelanes": ("--clips", "2"), "llamas": ("--clips", "2", "--frames", "3")}


def _invoke(arguments) -> str:
    result = CliRunner().invoke(main, [str(a) for a in arguments])
    assert result.exit_code == 0, result.output
    return result.output


def _other_score(name: str, out: Path) -> list:
    """The benchmark's `score` of the lanes synth wrote for `run`, where the layouts allow it."""
    if name == "culane":
        return ["score", "culane", "--data-root", out / "data", "--pred-root", out / "maps"]
    if name == "vil100":
        return ["score", "vil100", "--labels", out / "data" / "anno_txt", "--pred-root", out / "maps", "--sizes",
                out / "data" / "sizes.json", "--workers", "1"]
    return []  # TuSimple's lanes are every frame's (for run), its labels the last one's


@pytest.mark.parametrize("name", sorted(SETS))
def test_the_synthetic_set_scores_without_a_warning(tmp_path, name):
    out = tmp_path / "set"
    printed = _invoke(["synth", "--dataset", name, "--out", out, "--maps-format", "lanes", *SETS[name]])
    command = shlex.split(printed.strip().splitlines()[-1])
    assert command[0] == "roneld-eval"
    extra = ["--out", tmp_path / "result"] if command[1] == "run" else []
    for arguments in (command[1:] + extra, _other_score(name, out)):
        if arguments:
            said = _invoke([*arguments, "--quiet"])
            assert "warning" not in said.lower(), said
