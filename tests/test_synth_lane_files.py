"""`synth --dataset NAME` for the benchmarks scored from lane files alone (OpenLane, CurveLanes,
LLAMAS): labels and a detector's lanes in each one's format, scored end to end by the command
synth prints, the same bytes for the same seed."""

from __future__ import annotations

import shlex
from pathlib import Path

import pytest
from click.testing import CliRunner

from roneld_eval.cli import main


def synth(name: str, out: Path, *extra: str) -> list[str]:
    result = CliRunner().invoke(main, ["synth", "--dataset", name, "--out", str(out), *extra])
    assert result.exit_code == 0, result.output
    assert "labels: " in result.output and "Score them with:" in result.output
    command = shlex.split(result.output.strip().splitlines()[-1])
    assert command[:3] == ["roneld-eval", "score", name]
    return command[1:]


@pytest.mark.parametrize("name, header", [
    ("openlane", "method,matching,threshold,tp,fp,fn,precision,recall,f1"),
    ("curvelanes", "method,score_threshold,chosen,hits,predicted,truth,precision,recall,f1"),
    ("llamas", "method,threshold,tp,fp,fn,precision,recall,f1,ap_l1,ap_l0,ap_r0,ap_r1,ap_mean"),
])
def test_the_printed_command_scores_the_generated_set(tmp_path, name, header):
    command = synth(name, tmp_path / "my set's copy")  # pasted into a shell: quoted
    result = CliRunner().invoke(main, [*command, "--out", str(tmp_path / "scores"), "--quiet"])
    assert result.exit_code == 0, result.output
    official = (tmp_path / "scores" / "official.csv").read_text().splitlines()
    assert official[0] == header and len(official) > 1
    synth(name, tmp_path / "again")
    for path in sorted((tmp_path / "set").rglob("*")):
        if path.is_file():
            assert (tmp_path / "again" / path.relative_to(tmp_path / "set")).read_bytes() == path.read_bytes(), path


def test_the_generated_llamas_labels_score_as_the_official_script_scores_them(tmp_path):
    # unsupervised_llamas 9b99f46 culane_metric/evaluate.py (eval_predictions, discrete IoU), run
    # unchanged on this very set (synth --dataset llamas, seed 0, 3 clips x 10 frames): 115/8/5.
    # A change to the generator needs that script run again.
    command = synth("llamas", tmp_path / "set")
    result = CliRunner().invoke(main, [*command, "--iou", "0.5", "--out", str(tmp_path / "scores"), "--quiet"])
    assert result.exit_code == 0, result.output
    assert (tmp_path / "scores" / "official.csv").read_text().splitlines()[1] == \
        f"predictions,0.50,115,8,5,{115 / 123!r},{115 / 120!r},0.9465020576131687,,,,,"
