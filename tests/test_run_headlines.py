"""What a run shows a reader beyond the paper's table: the official scores papers quote (console
and report.html), the note when the paper's two thickness rules draw differently, a report that
does not carry the user's directory layout, and compare refusing one result given twice."""

from __future__ import annotations

import importlib.metadata
import json
import re
import shutil

import pandas as pd
import pytest
from click.testing import CliRunner

from roneld_eval.benchmarks import benchmark_for, names
from roneld_eval.cli import main
from roneld_eval.comparison import compare
from roneld_eval.config import PaperMetricParams
from roneld_eval.errors import ConfigError


def test_the_console_shows_the_official_headline_beside_the_papers_table(tmp_path):
    result = CliRunner().invoke(main, ["run", "--workers", "1", "--pft-ablation", "--out", str(tmp_path / "out")])
    assert result.exit_code == 0, result.output
    official = pd.read_csv(tmp_path / "out" / "official.csv")
    text = result.stdout
    assert "official CULane scores" in text
    headline = text[text.index("official CULane scores"):]
    for record in official.to_dict("records"):
        shown = f"| {record['category']} | {record['f1']:.4f} |"
        assert (shown in headline) == (record["category"] in ("all", "ego")), shown
    assert "| tp |" not in headline  # counts stay in official.csv


def test_the_report_shows_the_headline_and_folds_every_row_below(fixture_run):
    _, out = fixture_run
    page = (out / "report.html").read_text()
    section = page[page.index("<h2>Official scores</h2>"):]
    section = section[:section.index("<h2>", 4)]
    summary, _, folded = section.partition("<details>")
    assert folded, "the full official.csv is folded below the headline"
    official = pd.read_csv(out / "official.csv")
    assert summary.count("<tr>") == 1 + int(official["category"].isin(["all", "ego"]).sum())
    assert folded.count("<tr") == 1 + len(official)  # pandas' header row carries a style


def test_a_report_names_the_data_folder_not_its_whole_path(tmp_path, culane_set):
    data, maps = culane_set / "data", culane_set / "maps"
    out = tmp_path / "out"
    result = CliRunner().invoke(main, ["run", "--dataset", "culane", "--data-root", str(data), "--maps-root",
                                       str(maps), "--maps-format", "lanes", "--workers", "1", "--quiet",
                                       "--out", str(out)])
    assert result.exit_code == 0, result.output
    page = (out / "report.html").read_text()
    assert str(data) not in page and str(tmp_path) not in page
    assert f".../{data.name}" in page
    assert json.loads((out / "summary.json").read_text())["data_root"] == str(data)  # kept where it is asked for


def test_the_thickness_rules_are_named_where_they_differ():
    width = PaperMetricParams()
    note = width.other_rule_note(976, 351)
    assert note is not None
    assert "20 px" in note and "37 px" in note and "19 and 36 px" in note
    assert note.endswith("--set paper.thickness_rule=height")
    assert PaperMetricParams(thickness_rule="height").other_rule_note(976, 351).endswith(
        "--set paper.thickness_rule=width")
    for size in ((800, 288), (1600, 576), (400, 144)):  # proportional: both rules draw alike
        assert width.other_rule_note(*size) is None


def test_a_run_on_the_real_clip_says_which_rule_drew_it(real_clip_tree, tmp_path):
    data, maps = real_clip_tree
    out = tmp_path / "out"
    result = CliRunner().invoke(main, ["run", "--dataset", "culane", "--data-root", str(data), "--maps-root",
                                       str(maps), "--maps-format", "scnn-png", "--workers", "1", "--out", str(out)])
    assert result.exit_code == 0, result.output
    line = next(line for line in result.stderr.splitlines() if "thickness_rule" in line)
    assert line.startswith("note: on these 976x351 maps") and "--set paper.thickness_rule=height" in line
    notes = json.loads((out / "summary.json").read_text())["notes"]
    assert line.removeprefix("note: ") in notes
    assert "--set paper.thickness_rule=height" in (out / "report.html").read_text()


def test_compare_refuses_one_result_given_twice_as_two_seeds(fixture_run, tmp_path):
    _, out = fixture_run
    copy = tmp_path / "copy"
    shutil.copytree(out, copy)
    with pytest.raises(ConfigError, match=r"cannot average .* as two runs of 'SCNN': every IoU of every method "
                                          r"is the same in both"):
        compare([out, copy], tmp_path / "compared")
    result = CliRunner().invoke(main, ["compare", str(out), str(copy), "--out", str(tmp_path / "compared")])
    assert result.exit_code == 2 and result.stderr.count("\n") == 1 and str(copy) in result.stderr
    assert not (tmp_path / "compared").exists()


def test_compare_still_averages_runs_that_differ_in_one_iou(fixture_run, tmp_path):
    _, out = fixture_run
    copy = tmp_path / "copy"
    shutil.copytree(out, copy)
    per_frame = copy / "per_frame.csv"
    lines = per_frame.read_text().splitlines(keepends=True)
    # one IoU moved a little, every count unchanged: another seed, not the same result
    frame, side, method, iou = lines[1].rstrip("\n").split(",")
    nudged = float(iou) + (1e-9 if float(iou) < 0.5 else -1e-9)
    lines[1] = f"{frame},{side},{method},{nudged!r}\n"
    per_frame.write_text("".join(lines))
    compare([out, copy], tmp_path / "compared")


def test_the_package_says_every_builtin_benchmark_it_scores():
    description = importlib.metadata.metadata("roneld-eval")["Summary"]
    builtin = [name for name in names() if importlib.metadata.entry_points(group="roneld_eval.benchmarks")[name]
               .value.startswith("roneld_eval.")]
    for name in builtin:
        shown = benchmark_for(name).display_name
        assert re.sub(r" 2D$", "", shown) in description, shown
    help_text = CliRunner().invoke(main, ["--help"]).output
    assert "CULane and TuSimple" not in help_text and "score BENCHMARK" in help_text


def test_compare_calls_a_run_file_that_is_a_fifo_or_a_device_what_it_is(fixture_run, tmp_path):
    # Both were "missing from this run folder", which they are not.
    import os

    _, out = fixture_run
    copy = tmp_path / "copy"
    shutil.copytree(out, copy)
    (copy / "per_frame.csv").unlink()
    (copy / "per_frame.csv").symlink_to("/dev/zero")
    with pytest.raises(Exception, match="per_frame.csv: is a device, not a regular file"):
        compare([out, copy], tmp_path / "compared")
    (copy / "per_frame.csv").unlink()
    os.mkfifo(copy / "per_frame.csv")
    result = CliRunner().invoke(main, ["compare", str(out), str(copy), "--out", str(tmp_path / "compared")])
    assert result.exit_code == 2 and "per_frame.csv: is a FIFO (named pipe), not a regular file" in result.stderr, \
        result.output
