"""`run --diagnose`: the lanes a run saves, scored with its benchmark's --diagnose at the run's own
thresholds and lane width over the frames it scored, add up to the run's official.csv; the run's
other files stay what they are; report.html shows the error table and the gallery; and `show` of a
diagnosed score writes a report.html of its own, with the sweep."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner

from roneld_eval.cli import main

DIAGNOSIS_FILES = {"errors.csv", "errors.md", "errors.png", "frames.csv.gz", "gallery.json", "gallery.png"}


def invoke(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def _files(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def _adds_up(out: Path, by: list[str]) -> int:
    """frames.csv.gz and errors.csv against official.csv's rows of all lanes; the rows compared."""
    official = pd.read_csv(out / "official.csv", dtype={"threshold": str}, keep_default_na=False)
    official = official[official["category"] != "ego"]
    frames = pd.read_csv(out / "frames.csv.gz", dtype={"threshold": str}, keep_default_na=False)
    errors = pd.read_csv(out / "errors.csv", dtype={"threshold": str}, keep_default_na=False)
    every = official[official["category"] == "all"].set_index(by)[["tp", "fp", "fn"]].sort_index()
    summed = frames.groupby(by)[["tp", "fp", "fn"]].sum().sort_index()
    pd.testing.assert_frame_equal(summed, every, check_names=False)
    keys = ["method", "category", *[column for column in by if column == "threshold"]]
    sides = errors.pivot_table(index=keys, columns="side", values="count", aggfunc="sum")
    # VIL-100's official.csv also has a row per video: frames.csv.gz's sequences (its test)
    counted = official[official["category"].isin(set(errors["category"]))].set_index(keys)
    assert len(counted) == len(sides)
    assert list(counted["fp"]) == list(sides.loc[counted.index, "fp"])
    assert list(counted["fn"]) == list(sides.loc[counted.index, "fn"])
    return len(counted)


@pytest.fixture(scope="module")
def culane_runs(tmp_path_factory):
    """The CULane fixture run with --save-lanes and with --diagnose, both untimed (same bytes)."""
    base = tmp_path_factory.mktemp("run-diagnose")
    for name, option in (("saved", "--save-lanes"), ("diagnosed", "--diagnose")):
        result = invoke("run", "--pft-ablation", option, "--no-timings", "--workers", "1", "--out", base / name)
        assert result.exit_code == 0, result.output
    return base


def test_a_diagnosed_run_adds_up_to_its_official_table_and_leaves_its_other_files_alone(culane_runs):
    saved, diagnosed = _files(culane_runs / "saved"), _files(culane_runs / "diagnosed")
    added = {name for name in diagnosed if name not in saved}
    assert {name for name in added if "/" not in name} == DIAGNOSIS_FILES
    assert {name.split("/")[0] for name in added} == DIAGNOSIS_FILES | {"gallery"}
    assert set(saved) <= set(diagnosed)
    # the folder's manifest lists the files added; report.html shows them; summary.json records the diagnosis
    assert [name for name in saved if saved[name] != diagnosed[name]] == [".roneld-run.json", "report.html",
                                                                           "summary.json"]
    summaries = [json.loads((culane_runs / name / "summary.json").read_text()) for name in ("saved", "diagnosed")]
    assert summaries[1].pop("diagnosis")["loc_iou"] == 0.1 and summaries[0] == summaries[1]
    assert any(name.startswith("lanes/") for name in saved)  # the lanes it scored are kept, as --save-lanes
    assert _adds_up(culane_runs / "diagnosed", ["method"]) == 3 * 5  # three methods, four lists and all
    frames = pd.read_csv(culane_runs / "diagnosed" / "frames.csv.gz", keep_default_na=False)
    per_frame = pd.read_csv(culane_runs / "diagnosed" / "per_frame.csv")
    assert set(frames["frame"]) == set(per_frame["frame"]) and frames["frame"].nunique() == 40
    assert set(frames["method"]) == {"baseline", "roneld", "roneld-nopft"}


def test_report_html_shows_the_error_table_and_the_gallery(culane_runs):
    page = (culane_runs / "diagnosed" / "report.html").read_text()
    plain = (culane_runs / "saved" / "report.html").read_text()
    headings = re.findall(r"<h2>([^<]*)</h2>", page)
    assert headings == re.findall(r"<h2>([^<]*)</h2>", plain) + ["Why F1 is not higher: error types",
                                                                  "Gallery: the worst frames"]
    errors = pd.read_csv(culane_runs / "diagnosed" / "errors.csv", keep_default_na=False)
    loc = errors[(errors["method"] == "baseline") & (errors["category"] == "all") & (errors["side"] == "fp")
                 & (errors["type"] == "Loc")]["count"].item()
    section = page.split("<h2>Why F1 is not higher", 1)[1]
    row = re.search(r"<tr><td>SCNN</td><td>all</td>(.*?)</tr>", section)  # named as the run's tables name it
    assert row is not None and f"<td>{loc}</td>" in row.group(1)
    assert "<b>Loc</b>" in page and "**Loc**" not in page
    named = (culane_runs / "diagnosed" / "errors.md").read_text()
    assert "| SCNN + RONELD | all |" in named and "| roneld |" not in named
    section = page.split("<h2>Gallery: the worst frames", 1)[1]
    assert section.count('src="data:image/png;base64,') == 1 and "ground truth in blue" in section
    assert "Score sweep" not in page  # a run's lanes carry no scores
    assert len(list((culane_runs / "diagnosed" / "gallery").glob("*.png"))) >= 3


def test_a_limited_run_is_diagnosed_over_its_own_frames(tmp_path):
    result = invoke("run", "--diagnose", "--limit", "2", "--loc-iou", "0.3", "--workers", "1", "--out", tmp_path / "o")
    assert result.exit_code == 0, result.output
    assert re.search(r"^SCNN at IoU > 0\.50, all frames: FP Loc \d+", result.output, re.MULTILINE)
    frames = pd.read_csv(tmp_path / "o" / "frames.csv.gz", keep_default_na=False)
    assert frames["sequence"].nunique() == 2 and frames["frame"].nunique() == 20
    assert _adds_up(tmp_path / "o", ["method"]) > 0
    assert "at least 0.3 (--loc-iou)" in (tmp_path / "o" / "errors.md").read_text()
    recorded = json.loads((tmp_path / "o" / "summary.json").read_text())["diagnosis"]
    assert recorded["loc_iou"] == 0.3 and recorded["thresholds"] == ["0.50"]


def test_a_vil100_run_is_diagnosed_at_both_of_its_thresholds(tmp_path):
    assert invoke("synth", "--dataset", "vil100", "--out", tmp_path / "set", "--clips", "3", "--frames", "6",
                  "--maps-format", "lanes").exit_code == 0
    result = invoke("run", "--dataset", "vil100", "--data-root", tmp_path / "set" / "data", "--maps-root",
                    tmp_path / "set" / "maps", "--diagnose", "--workers", "1", "--out", tmp_path / "out", "--quiet")
    assert result.exit_code == 0, result.output
    assert _adds_up(tmp_path / "out", ["method", "threshold"]) >= 2 * 2 * 2  # methods, thresholds, a scenario and all
    frames = pd.read_csv(tmp_path / "out" / "frames.csv.gz", dtype={"threshold": str}, keep_default_na=False)
    assert set(frames["threshold"]) == {"0.50", "0.80"} and frames["sequence"].nunique() == 3
    official = pd.read_csv(tmp_path / "out" / "official.csv", dtype={"threshold": str}, keep_default_na=False)
    videos = official[official["category"].isin(set(frames["sequence"]))].set_index(["method", "category",
                                                                                      "threshold"])
    by_video = frames.groupby(["method", "sequence", "threshold"])[["tp", "fp", "fn"]].sum()
    assert len(videos) == 2 * 3 * 2
    assert (by_video.loc[videos.index].to_numpy() == videos[["tp", "fp", "fn"]].to_numpy()).all()


def test_a_limited_llamas_run_is_diagnosed_over_its_recordings_alone(tmp_path):
    assert invoke("synth", "--dataset", "llamas", "--maps-format", "llamas-png", "--out", tmp_path / "set",
                  "--clips", "3", "--frames", "4").exit_code == 0
    result = invoke("run", "--dataset", "llamas", "--data-root", tmp_path / "set" / "labels", "--maps-root",
                    tmp_path / "set" / "predictions", "--diagnose", "--limit", "2", "--workers", "1",
                    "--out", tmp_path / "out", "--quiet")
    assert result.exit_code == 0, result.output
    assert "warning" not in result.output  # the recording it did not evaluate has no lanes, and is not scored
    assert _adds_up(tmp_path / "out", ["method", "threshold"]) == 2 * 10
    frames = pd.read_csv(tmp_path / "out" / "frames.csv.gz", keep_default_na=False)
    assert frames["sequence"].nunique() == 2 and frames["frame"].nunique() == 8


@pytest.mark.parametrize("args, said", [
    (["--dataset", "tusimple", "--diagnose"], "does not match lanes by IoU"),
    (["--loc-iou", "0.2"], "give --diagnose too"),
    (["--diagnose", "--loc-iou", "1.5"], "must be in (0, 1]"),
    (["--diagnose", "--shard", "1/2"], "a shard does not"),
    (["--diagnose", "--executor", "dask"], "--executor dask"),
])
def test_run_refuses_a_diagnosis_it_cannot_give_before_any_work(tmp_path, args, said):
    result = invoke("run", *args, "--out", tmp_path / "out")
    assert result.exit_code == 2, result.output
    assert said in result.output and "Traceback" not in result.output
    assert not (tmp_path / "out").exists()
    if "--shard" not in args and "--executor" not in args:  # which --dry-run refuses for itself
        dry = invoke("run", *args, "--dry-run")
        assert dry.exit_code == 2 and said in dry.output, dry.output  # a dry run said all was well


def test_show_of_a_diagnosed_score_writes_a_report_with_its_sweep_and_gallery(tmp_path):
    assert invoke("synth", "--dataset", "culane", "--out", tmp_path / "set", "--maps-format", "lanes",
                  "--clips", "2").exit_code == 0
    scored = invoke("score", "culane", "--data-root", tmp_path / "set" / "data", "--pred-root",
                    f"det={tmp_path / 'set' / 'maps'}", "--diagnose", "--score-sweep", "--out", tmp_path / "s",
                    "--quiet")
    assert scored.exit_code == 0, scored.output
    shown = invoke("show", "--run", tmp_path / "s")
    assert shown.exit_code == 0, shown.output
    page = (tmp_path / "s" / "show" / "report.html").read_text()
    assert re.findall(r"<h2>([^<]*)</h2>", page) == ["Why F1 is not higher: error types", "Score sweep",
                                                    "Gallery: the worst frames"]
    sweep = pd.read_csv(tmp_path / "s" / "sweep_scores.csv", dtype=str, keep_default_na=False)
    best = sweep[(sweep["category"] == "all") & (sweep["best"] == "True")]
    assert len(best) == 1 and f"<td>{best['score_threshold'].item()}</td>" in page
    assert page.count('src="data:image/png;base64,') == 3  # errors.png, sweep_scores.png, gallery.png
    too_many = invoke("show", "--run", tmp_path / "s", "--worst", "7", "--out", tmp_path / "seven")
    assert too_many.exit_code == 2 and "keeps 6 frames a reason" in too_many.output
    (tmp_path / "s" / "errors.md").rename(tmp_path / "errors.md")
    (tmp_path / "s" / "errors.md").symlink_to(tmp_path / "errors.md")
    linked = invoke("show", "--run", tmp_path / "s", "--out", tmp_path / "linked")
    assert linked.exit_code == 2 and "a symbolic link" in linked.output and not (tmp_path / "linked").exists()
    (tmp_path / "s" / "errors.md").unlink()
    (tmp_path / "errors.md").rename(tmp_path / "s" / "errors.md")
    picture = (tmp_path / "s" / "errors.png").read_bytes()
    (tmp_path / "s" / "errors.png").write_bytes(b"not a picture" * 100)
    garbage = invoke("show", "--run", tmp_path / "s", "--out", tmp_path / "garbage")
    assert garbage.exit_code == 2 and "not a PNG image" in garbage.output
    (tmp_path / "s" / "errors.png").write_bytes(picture)

    (tmp_path / "s" / "sweep_scores.csv").write_text("method,f1\nx,\"unclosed\n")
    broken = invoke("show", "--run", tmp_path / "s", "--out", tmp_path / "again")
    assert broken.exit_code == 2 and "sweep_scores.csv" in broken.output and "Traceback" not in broken.output
    assert not (tmp_path / "again").exists()


def test_the_real_clips_diagnosis_adds_up_to_its_official_table(real_clip_tree, tmp_path):
    data, maps = real_clip_tree
    result = invoke("run", "--data-root", data, "--maps-root", maps, "--maps-format", "scnn-png", "--pft-ablation",
                    "--diagnose", "--workers", "1",
                    "--out", tmp_path / "out", "--quiet")
    assert result.exit_code == 0, result.output
    assert _adds_up(tmp_path / "out", ["method"]) == 3  # one video, no category lists: all lanes
    errors = pd.read_csv(tmp_path / "out" / "errors.csv", keep_default_na=False)
    assert errors["count"].sum() > 0


def test_a_diagnosis_reads_only_the_labels_of_the_frames_the_run_scored(tmp_path):
    # A broken label the run skipped (--on-error skip), or never read (--limit), stopped the
    # diagnosis, which scored the whole list, and took the run's results with it.
    made = invoke("synth", "--dataset", "culane", "--out", tmp_path / "set", "--clips", "3", "--frames", "4")
    assert made.exit_code == 0
    labels = sorted((tmp_path / "set" / "data").rglob("*.lines.txt"))
    labels[0].write_text("garbage\n")  # in the first clip
    labels[-1].write_text("garbage\n")  # in the last
    common = ["run", "--data-root", tmp_path / "set" / "data", "--maps-root", tmp_path / "set" / "maps", "--diagnose",
              "--workers", "1", "--quiet"]
    skipped = invoke(*common, "--on-error", "skip", "--out", tmp_path / "skip")
    assert skipped.exit_code == 0, skipped.output
    frames = pd.read_csv(tmp_path / "skip" / "frames.csv.gz", keep_default_na=False)
    assert frames["frame"].nunique() == 12 - 2 and _adds_up(tmp_path / "skip", ["method"]) > 0
    labels[0].write_text(labels[1].read_text())
    limited = invoke(*common, "--limit", "1", "--out", tmp_path / "limit")
    assert limited.exit_code == 0, limited.output
    assert pd.read_csv(tmp_path / "limit" / "frames.csv.gz")["frame"].nunique() == 4


def test_compare_of_a_run_and_a_diagnosed_score_names_the_folder_that_does_not_fit(culane_runs, tmp_path):
    from roneld_eval.api import fixture_roots

    data, _ = fixture_roots("culane")
    scored = invoke("score", "culane", "--data-root", data, "--pred-root", culane_runs / "diagnosed" / "lanes",
                    "--diagnose", "--out", tmp_path / "scored", "--quiet")
    assert scored.exit_code == 0, scored.output
    result = invoke("compare", culane_runs / "diagnosed", tmp_path / "scored", "--out", tmp_path / "compared")
    assert result.exit_code == 2 and "Traceback" not in result.output
    assert f"{culane_runs / 'diagnosed'} is not a score folder written with --diagnose" in result.output
    assert "--label" not in result.output  # none was given
    # the same frames, scored by `score culane --diagnose` on the run's lanes: the same counts, byte for byte
    run_frames = (culane_runs / "diagnosed" / "frames.csv.gz").read_bytes()
    assert (tmp_path / "scored" / "frames.csv.gz").read_bytes() == run_frames
