"""`score ... --diagnose` and `--score-sweep`: the error types add up to the official FP and FN,
frames.csv.gz adds up to official.csv, the sweep equals scoring files that hold only the lanes
kept, and the official tables stay byte for byte what they are without the options."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from roneld_eval.benchmarks.culane.score import score_culane
from roneld_eval.benchmarks.culane.synth import synth_lane_files
from roneld_eval.cli import main
from roneld_eval.errors import ConfigError

HEADLINE_FILES = ("official.csv", "summary.csv", "summary.md")


@pytest.fixture(scope="module")
def lanes(tmp_path_factory):
    """120 frames of ground truth and noisy predictions (two category lists), and a second method."""
    root = tmp_path_factory.mktemp("diagnose")
    gt, pred = synth_lane_files(root, frames=120, seed=7)
    listed = [line.lstrip("/") for line in (gt / "list" / "test.txt").read_text().split()]
    (gt / "list" / "test_split").mkdir()
    (gt / "list" / "test_split" / "test0_normal.txt").write_text("".join(f"{r} \n" for r in listed[:70]))
    (gt / "list" / "test_split" / "test1_curve.txt").write_text("".join(f"{r} \n" for r in listed[70:]))
    other = synth_lane_files(root / "other", frames=120, seed=8)[1]
    return gt, {"noisy": pred, "other": other}


def invoke(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def test_diagnosis_leaves_the_official_tables_as_they_are_and_adds_up_to_them(lanes, tmp_path):
    gt, roots = lanes
    plain = score_culane(gt, roots, iou="0.1,0.5,0.75", workers=1, out=tmp_path / "plain")
    diagnosed = score_culane(gt, roots, iou="0.1,0.5,0.75", workers=2, out=tmp_path / "diag", diagnose=True,
                             loc_iou=0.2)
    for name in HEADLINE_FILES:
        assert (tmp_path / "plain" / name).read_bytes() == (tmp_path / "diag" / name).read_bytes()
    assert plain.official_rows == diagnosed.official_rows
    official = pd.read_csv(tmp_path / "diag" / "official.csv", dtype={"threshold": str})
    errors = pd.read_csv(tmp_path / "diag" / "errors.csv", dtype={"threshold": str})
    sides = errors.pivot_table(index=["method", "category", "threshold"], columns="side", values="count",
                               aggfunc="sum")
    counted = official.set_index(["method", "category", "threshold"])
    assert len(counted) == 2 * 3 * 3
    np.testing.assert_array_equal(counted["fp"].to_numpy(), sides.loc[counted.index, "fp"].to_numpy())
    np.testing.assert_array_equal(counted["fn"].to_numpy(), sides.loc[counted.index, "fn"].to_numpy())
    loc = errors[errors["type"] == "Loc"].pivot_table(index=["method", "category", "threshold"], columns="side",
                                                      values="count")
    assert (loc["fp"] == loc["fn"]).all()
    assert errors["count"].sum() > 0 and (errors.loc[errors["type"] == "Loc", "count"] > 0).any()
    # every frame's counts add up to the official rows of every category
    frames = pd.read_csv(tmp_path / "diag" / "frames.csv.gz", dtype={"threshold": str}, keep_default_na=False)
    assert len(frames) == 120 * 2 * 3
    assert set(frames["category"]) == {"normal", "curve"}
    for category in ("normal", "curve"):
        mine = frames[frames["category"] == category].groupby(["method", "threshold"])[["tp", "fp", "fn"]].sum()
        theirs = official[official["category"] == category].set_index(["method", "threshold"])[["tp", "fp", "fn"]]
        pd.testing.assert_frame_equal(mine.sort_index(), theirs.sort_index(), check_names=False)
    by_type = frames.groupby(["method", "threshold"])[["fp_loc", "fp_dupe", "fp_bkg", "fn_loc", "fn_miss"]].sum()
    all_rows = errors[errors["category"] == "all"]
    for (method, threshold), row in by_type.iterrows():
        mine = all_rows[(all_rows["method"] == method) & (all_rows["threshold"] == threshold)]
        assert mine["count"].tolist() == row.tolist()


def test_the_files_are_the_same_bytes_every_time(lanes, tmp_path):
    gt, roots = lanes
    for out in ("one", "two"):
        score_culane(gt, roots["noisy"], workers=1, out=tmp_path / out, diagnose=True)
    for name in ("errors.csv", "errors.md", "frames.csv.gz", "errors.png"):
        assert (tmp_path / "one" / name).read_bytes() == (tmp_path / "two" / name).read_bytes()


def test_a_score_sweep_equals_scoring_only_the_lanes_kept(culane_set, tmp_path):
    data, detector = culane_set / "data", culane_set / "maps"
    score = score_culane(data, detector, iou="0.3,0.5", workers=1, out=tmp_path / "swept",
                         score_sweep="0.0,0.4,0.5,0.9")
    swept = pd.read_csv(tmp_path / "swept" / "sweep_scores.csv", dtype={"threshold": str, "score_threshold": str})
    assert not (tmp_path / "swept" / "errors.csv").exists()  # only what was asked for
    official = pd.read_csv(tmp_path / "swept" / "official.csv", dtype={"threshold": str})
    at_zero = swept[swept["score_threshold"] == "0.00"].set_index(["category", "threshold"])
    pd.testing.assert_frame_equal(at_zero[["tp", "fp", "fn"]].sort_index(),
                                  official.set_index(["category", "threshold"])[["tp", "fp", "fn"]].sort_index())
    for keep in ("0.40", "0.90"):
        kept = tmp_path / f"kept{keep}"
        shutil.copytree(detector, kept)
        for lines in kept.rglob("*.lines.txt"):
            scores = [float(v) for v in lines.with_name(lines.name[:-10] + ".scores.txt").read_text().split()]
            rows = lines.read_text().splitlines()
            lines.write_text("".join(f"{row}\n" for row, s in zip(rows, scores) if s >= float(keep)))
        alone = score_culane(data, kept, iou="0.3,0.5", workers=1)
        theirs = alone.official.set_index(["category", "threshold"])[["tp", "fp", "fn"]].sort_index()
        mine = swept[swept["score_threshold"] == keep].set_index(["category", "threshold"])[["tp", "fp", "fn"]]
        pd.testing.assert_frame_equal(mine.sort_index(), theirs)
    assert swept.groupby(["category", "threshold"])["best"].sum().eq(1).all()
    assert score.diagnosed is not None and score.diagnosed.sweep.rule == "score >= threshold"


def test_the_command_reports_the_errors_and_refuses_what_it_cannot_keep(lanes, tmp_path):
    gt, roots = lanes
    result = invoke("score", "culane", "--data-root", gt, "--pred-root", roots["noisy"], "--diagnose", "--workers", 1,
                    "--out", tmp_path / "out")
    assert result.exit_code == 0, result.output
    assert "all frames: FP Loc" in result.output and "(errors.md)" in result.output
    for extra, says in ((["--loc-iou", "0.2"], "give --diagnose too"),
                        (["--diagnose", "--loc-iou", "0"], "must be in (0, 1]"),
                        (["--score-sweep", "1.5"], "1.5")):
        result = invoke("score", "culane", "--data-root", gt, "--pred-root", roots["noisy"], *extra,
                        "--out", tmp_path / "refused")
        assert result.exit_code == 2, result.output
        assert says in result.output and "Traceback" not in result.output
        assert not (tmp_path / "refused").exists()
    with pytest.raises(ConfigError, match="give --diagnose too"):
        score_culane(gt, roots["noisy"], loc_iou=0.3)


def test_the_sweep_of_a_malformed_scores_file_names_it(lanes, tmp_path):
    gt, roots = lanes
    copy = tmp_path / "pred"
    shutil.copytree(roots["noisy"], copy)
    target = sorted(copy.rglob("*.lines.txt"))[3]
    n_lanes = len(target.read_text().splitlines())
    bad = target.with_name(target.name[:-10] + ".scores.txt")
    bad.write_text("0.5\n" * (n_lanes + 1))
    result = invoke("score", "culane", "--data-root", gt, "--pred-root", copy, "--score-sweep", "--workers", 1)
    assert result.exit_code == 2 and "Traceback" not in result.output
    assert Path(bad).name in result.output and "one score per lane line" in result.output


# ---- every benchmark that matches lanes by IoU ---------------------------------------------------

SCORED = {  # synth's folder -> the score command's inputs, and whether predictions carry scores
    "culane": (lambda s: ["--data-root", s / "data", "--pred-root", f"det={s / 'maps'}"],
               ["--maps-format", "lanes", "--clips", 2], True),
    "vil100": (lambda s: ["--labels", s / "data" / "anno_txt", "--sizes", s / "data" / "sizes.json", "--pred-root",
                          f"det={s / 'maps'}"], ["--maps-format", "lanes", "--clips", 2], True),
    "openlane": (lambda s: ["--labels", s / "labels", "--pred-root", f"det={s / 'predictions'}", "--iou", "0.3,0.5"],
                 [], False),
    "curvelanes": (lambda s: ["--labels", s / "labels", "--pred-root", f"det={s / 'predictions'}", "--image-root",
                              s / "images"], ["--clips", 12], True),
    "llamas": (lambda s: ["--labels", s / "labels", "--pred-root", f"det={s / 'predictions'}"],
               ["--maps-format", "lanes", "--clips", 2], False),
}


@pytest.mark.parametrize("benchmark", sorted(SCORED))
def test_every_iou_benchmark_diagnoses_what_its_official_table_counts(benchmark, tmp_path):
    inputs, synth_options, with_scores = SCORED[benchmark]
    result = invoke("synth", "--dataset", benchmark, "--out", tmp_path / "set", *(synth_options or ["--clips", 2]))
    assert result.exit_code == 0, result.output
    plain = invoke("score", benchmark, *inputs(tmp_path / "set"), "--workers", 1, "--out", tmp_path / "plain")
    assert plain.exit_code == 0, plain.output
    extra = ["--diagnose", "--loc-iou", "0.15"] + (["--score-sweep"] if with_scores else [])
    diagnosed = invoke("score", benchmark, *inputs(tmp_path / "set"), "--workers", 2, *extra, "--out",
                       tmp_path / "diag")
    assert diagnosed.exit_code == 0, diagnosed.output
    assert "all frames: FP Loc" in diagnosed.output
    kept = sorted(p.name for p in (tmp_path / "plain").iterdir() if not p.name.startswith("."))  # not the marker
    for name in kept:  # the official files as they were, byte for byte
        assert (tmp_path / "plain" / name).read_bytes() == (tmp_path / "diag" / name).read_bytes(), name
    added = {"errors.csv", "errors.md", "errors.png", "frames.csv.gz", "gallery.json"} | (
        {"sweep_scores.csv", "sweep_scores.png"} if with_scores else set())
    assert set(p.name for p in (tmp_path / "diag").iterdir() if not p.name.startswith(".")) == set(kept) | added
    official = pd.read_csv(tmp_path / "diag" / "official.csv", dtype=str, keep_default_na=False)
    if "category" in official:
        official = official[official["category"] == "all"]
    if "hits" in official:  # CurveLanes: hits, predicted and truth lanes at the fixed score threshold, IoU > 0.5
        official = official[official["chosen"] == "fixed"].astype({"hits": int, "predicted": int, "truth": int})
        official = official.assign(threshold="0.50", tp=official["hits"], fp=official["predicted"] - official["hits"],
                                   fn=official["truth"] - official["hits"])
    keys = ["method", "matching", "threshold"] if "matching" in official else ["method", "threshold"]
    official = official.set_index(keys)[["tp", "fp", "fn"]].astype(int).sort_index()
    frames = pd.read_csv(tmp_path / "diag" / "frames.csv.gz", dtype={"frame": str, "threshold": str, "matching": str},
                         keep_default_na=False)
    pd.testing.assert_frame_equal(frames.groupby(keys)[["tp", "fp", "fn"]].sum().sort_index(), official)
    errors = pd.read_csv(tmp_path / "diag" / "errors.csv", dtype={"threshold": str}, keep_default_na=False)
    errors = errors[errors["category"] == "all"]
    sides = errors.pivot_table(index=keys, columns="side", values="count", aggfunc="sum").sort_index()
    assert sides["fp"].tolist() == official["fp"].tolist() and sides["fn"].tolist() == official["fn"].tolist()
    # the gallery: each chosen frame's lanes as scored, drawn by `show`
    gallery = json.loads((tmp_path / "diag" / "gallery.json").read_text())
    assert bool(gallery["pictures"]) == bool((frames["fp"] + frames["fn"]).sum())  # a frame a picture, if wrong
    assert all(picture["reasons"] for picture in gallery["pictures"])
    for picture in gallery["pictures"]:
        counts = frames[(frames["frame"] == picture["frame"]) & (frames["threshold"] == gallery["threshold"])]
        first = counts.iloc[0]
        assert list(picture["counts"].values())[0] == [first["tp"], first["fp"], first["fn"]]
        assert len(picture["truth"]) == first["tp"] + first["fn"]
        assert len(list(picture["predicted"].values())[0]) == first["tp"] + first["fp"]
    shown = invoke("show", "--run", tmp_path / "diag", "--worst", 1)
    assert shown.exit_code == 0, shown.output
    if gallery["pictures"]:
        assert list((tmp_path / "diag" / "show" / "gallery").iterdir())
        assert (tmp_path / "diag" / "show" / "gallery.png").is_file()
    if with_scores:
        swept = pd.read_csv(tmp_path / "diag" / "sweep_scores.csv", dtype={"threshold": str, "score_threshold": str},
                            keep_default_na=False)
        at_zero = swept[(swept["score_threshold"] == "0.00") & (swept["category"] == "all")]
        assert at_zero.set_index(keys)[["tp", "fp", "fn"]].sort_index().equals(official)


def test_tusimple_writes_each_frames_accuracy_and_rates_that_average_to_its_official_row(tmp_path):
    result = invoke("synth", "--dataset", "tusimple", "--out", tmp_path / "set", "--maps-format", "lanes")
    assert result.exit_code == 0, result.output
    scored = tmp_path / "labelled.json"  # lane.py scores the labelled frames, the last of each clip
    scored.write_text("".join(line for line in (tmp_path / "set" / "maps" / "predictions.json").open()
                              if '/20.jpg"' in line))
    labels = tmp_path / "set" / "data" / "test_label.json"
    plain = invoke("score", "tusimple", "--labels", labels, "--pred", scored, "--out", tmp_path / "plain")
    diagnosed = invoke("score", "tusimple", "--labels", labels, "--pred", scored, "--pred", f"again={scored}",
                       "--diagnose", "--out", tmp_path / "diag")
    assert plain.exit_code == 0 and diagnosed.exit_code == 0, diagnosed.output
    frames = pd.read_csv(tmp_path / "diag" / "frames.csv.gz", keep_default_na=False)
    official = pd.read_csv(tmp_path / "diag" / "official.csv").set_index("method")
    assert len(frames) == 2 * 3 and list(frames["method"].unique()) == ["labelled", "again"]
    for method, rows in frames.groupby("method"):
        for column in ("accuracy", "fp", "fn"):
            assert rows[column].mean() == pytest.approx(official.loc[method, column], abs=1e-12)
    assert (tmp_path / "plain" / "official.csv").read_text().splitlines()[1] == \
        (tmp_path / "diag" / "official.csv").read_text().splitlines()[1]
    refused = invoke("score", "tusimple", "--labels", labels, "--pred", scored, "--diagnose")
    assert refused.exit_code == 2 and "give --out" in refused.output and "Traceback" not in refused.output
    for k in (1, 2):  # shards merge into the same frames.csv.gz
        part = invoke("score", "tusimple", "--labels", labels, "--pred", scored, "--pred", f"again={scored}",
                      "--diagnose", "--shard", f"{k}/2", "--out", tmp_path / f"part{k}")
        assert part.exit_code == 0, part.output
    merged = invoke("merge", tmp_path / "part1", tmp_path / "part2", "--out", tmp_path / "merged")
    assert merged.exit_code == 0, merged.output
    for name in ("frames.csv.gz", "official.csv"):
        assert (tmp_path / "merged" / name).read_bytes() == (tmp_path / "diag" / name).read_bytes()


def test_compare_lists_the_frames_where_one_method_beats_the_other_most(lanes, tmp_path):
    gt, roots = lanes
    score_culane(gt, roots, workers=1, out=tmp_path / "both", diagnose=True)
    score_culane(gt, roots["noisy"], workers=1, out=tmp_path / "noisy", diagnose=True)
    score_culane(gt, roots["other"], workers=1, out=tmp_path / "other", diagnose=True)
    frames = pd.read_csv(tmp_path / "both" / "frames.csv.gz", keep_default_na=False).set_index(["method", "frame"])
    for given in ([tmp_path / "both"], [tmp_path / "noisy", tmp_path / "other"]):
        out = tmp_path / f"compared{len(given)}"
        result = invoke("compare", *given, "--out", out)
        assert result.exit_code == 0, result.output
        assert "## Where A beats B most" in result.output
        table = pd.read_csv(out / "frames_compared.csv", keep_default_na=False)
        assert len(table) == 120 and table["difference"].is_monotonic_decreasing
        top = table.iloc[0]
        noisy, other = frames.loc[("noisy", top["frame"])], frames.loc[("other", top["frame"])]
        assert top["difference"] == other["fp"] + other["fn"] - noisy["fp"] - noisy["fn"] > 0
    refused = invoke("compare", tmp_path / "noisy", "--out", tmp_path / "one")
    assert refused.exit_code == 2 and "hold 1 method (noisy: pred), not two" in refused.output
    score_culane(gt, roots["other"], workers=1, out=tmp_path / "fewer", diagnose=True, list_file=None,
                 iou="0.5,0.75")
    refused = invoke("compare", tmp_path / "noisy", tmp_path / "fewer", "--out", tmp_path / "mixed")
    assert refused.exit_code == 2 and "not scored on the same frames and thresholds" in refused.output
    (tmp_path / "bad").mkdir()
    (tmp_path / "bad" / "frames.csv.gz").write_bytes(b"not gzip")
    refused = invoke("compare", tmp_path / "bad", tmp_path / "noisy", "--out", tmp_path / "badout")
    assert refused.exit_code == 2 and "frames.csv.gz" in refused.output and "Traceback" not in refused.output


def test_show_draws_a_scores_gallery_over_its_images_and_refuses_an_edited_one(lanes, tmp_path):
    import cv2

    gt, roots = lanes
    score_culane(gt, roots["noisy"], workers=1, out=tmp_path / "scored", diagnose=True)
    gallery = json.loads((tmp_path / "scored" / "gallery.json").read_text())
    first = gallery["pictures"][0]
    images = tmp_path / "images"
    (images / first["frame"]).parent.mkdir(parents=True)
    cv2.imwrite(str(images / first["frame"]), np.full((590, 1640, 3), 200, np.uint8))
    result = invoke("show", "--run", tmp_path / "scored", "--image-root", images, "--out", tmp_path / "drawn")
    assert result.exit_code == 0, result.output
    picture = cv2.imread(str(tmp_path / "drawn" / "gallery" / "000.png"))
    assert picture[5, 5].tolist() == [200, 200, 200]  # the image, not the blank canvas
    assert first["reasons"][0].startswith("pred: most errors in ")
    refused = invoke("show", "--run", tmp_path / "scored", "--frame", first["frame"])
    assert refused.exit_code == 2 and "--frame and --method are for a run" in refused.output
    for edit in ({"pictures": "x"}, {"pictures": [{**first, "truth": [[[1, "x"]]]}]},
                 {"pictures": [{**first, "size": [0, 10]}]}, {"format": "other"},
                 {"pictures": [{**first, "size": [1, 20000]}]},  # 60 GB once scaled to the picture's width
                 {"pictures": [{**first, "truth": [[[10 ** 400, 1]]]}]},
                 {"pictures": [{**first, "image": "/etc/hostname"}]}, {"pictures": [{**first, "image": "../x.png"}]},
                 {"title": "x" * 100_000}, {"pictures": [{**first, "reasons": ["y" * 5000]}]}):
        (tmp_path / "scored" / "gallery.json").write_text(json.dumps({**gallery, **edit}))
        refused = invoke("show", "--run", tmp_path / "scored", "--out", tmp_path / "edited")
        assert refused.exit_code == 2 and "gallery.json" in refused.output and "Traceback" not in refused.output
        assert not (tmp_path / "edited").exists()
    (tmp_path / "scored" / "gallery.json").write_text('{"format": "roneld-eval gallery", "pictures": '
                                                      + "[" * 100_000 + "]" * 100_000 + "}")
    refused = invoke("show", "--run", tmp_path / "scored", "--out", tmp_path / "deep")
    assert refused.exit_code == 2 and "nested too deeply" in refused.output
    missing = invoke("show", "--run", tmp_path / "scored", "--image-root", tmp_path / "nowhere")
    assert missing.exit_code == 2 and "nowhere" in missing.output


def test_show_of_a_run_refuses_an_image_root(fixture_run, tmp_path):
    _, out = fixture_run
    refused = invoke("show", "--run", out, "--image-root", tmp_path, "--out", tmp_path / "shown")
    assert refused.exit_code == 2 and "--image-root is for a score's gallery" in refused.output
    assert not (tmp_path / "shown").exists()


@pytest.mark.parametrize("benchmark", sorted(SCORED))
def test_shards_of_a_diagnosed_score_merge_into_its_files(benchmark, tmp_path):
    inputs, synth_options, with_scores = SCORED[benchmark]
    result = invoke("synth", "--dataset", benchmark, "--out", tmp_path / "set", *(synth_options or ["--clips", 2]))
    assert result.exit_code == 0, result.output
    extra = ["--diagnose", "--loc-iou", "0.2"] + (["--score-sweep", "0.1:0.9:0.2"] if with_scores else [])
    whole = invoke("score", benchmark, *inputs(tmp_path / "set"), *extra, "--workers", 1, "--out", tmp_path / "whole")
    assert whole.exit_code == 0, whole.output
    for k in (1, 2, 3):  # a set of 2 clips in 3 shards: one shard scores no frame
        part = invoke("score", benchmark, *inputs(tmp_path / "set"), *extra, "--workers", 1, "--shard", f"{k}/3",
                      "--out", tmp_path / f"part{k}")
        assert part.exit_code == 0, part.output
    merged = invoke("merge", tmp_path / "part1", tmp_path / "part2", tmp_path / "part3", "--out", tmp_path / "merged")
    assert merged.exit_code == 0, merged.output
    written = sorted(p.name for p in (tmp_path / "whole").iterdir() if not p.name.startswith("."))
    assert "errors.csv" in written and "gallery.json" in written
    assert written == sorted(p.name for p in (tmp_path / "merged").iterdir() if not p.name.startswith("."))
    for name in written:
        assert (tmp_path / "whole" / name).read_bytes() == (tmp_path / "merged" / name).read_bytes(), name
    # a part whose error types were edited is refused in one line
    from roneld_eval.shards import ARRAYS_NAME
    arrays = dict(np.load(tmp_path / "part1" / ARRAYS_NAME))
    arrays["cat_diag_errors"] = arrays["cat_diag_errors"] + 1000
    np.savez(tmp_path / "part1" / ARRAYS_NAME, **arrays)
    refused = invoke("merge", tmp_path / "part1", tmp_path / "part2", tmp_path / "part3", "--out", tmp_path / "edited")
    assert refused.exit_code == 2 and "Traceback" not in refused.output, refused.output
    assert not (tmp_path / "edited").exists()


def test_without_out_the_console_names_no_file_and_diagnosed_sweeps_compare_as_sweeps(lanes, tmp_path):
    gt, roots = lanes
    said = invoke("score", "culane", "--data-root", gt, "--pred-root", roots["noisy"], "--diagnose", "--workers", 1)
    assert said.exit_code == 0 and "all frames: FP Loc" in said.output and "errors.md" not in said.output
    pattern = str(tmp_path / "ckpt" / "epoch_*")
    for epoch, root in ((1, roots["noisy"]), (2, roots["other"])):
        shutil.copytree(root, tmp_path / "ckpt" / f"epoch_{epoch}")
    for out in ("one", "two"):
        scored = invoke("score", "culane", "--data-root", gt, "--pred-root", pattern, "--diagnose", "--workers", 1,
                        "--out", tmp_path / out)
        assert scored.exit_code == 0, scored.output
    compared = invoke("compare", tmp_path / "one", tmp_path / "two", "--out", tmp_path / "sweeps")
    assert compared.exit_code == 0, compared.output
    assert (tmp_path / "sweeps" / "sweeps.csv").is_file()


@pytest.mark.parametrize("column, value", [("fp", -5), ("fp", 1.5), ("fp_loc", 100), ("fn", 2 ** 62)])
def test_compare_refuses_frame_counts_that_do_not_add_up(lanes, tmp_path, column, value):
    import gzip

    gt, roots = lanes
    score_culane(gt, roots, workers=1, out=tmp_path / "both", diagnose=True)
    path = tmp_path / "both" / "frames.csv.gz"
    frames = pd.read_csv(path, dtype={"threshold": str}, keep_default_na=False)
    frames[column] = frames[column].astype(object)
    frames.loc[3, column] = value
    path.write_bytes(gzip.compress(frames.to_csv(index=False).encode()))
    refused = invoke("compare", tmp_path / "both", "--out", tmp_path / "compared")
    assert refused.exit_code == 2 and "counts that add up" in refused.output, refused.output


def test_a_runs_saved_lanes_diagnosed_add_up_to_the_runs_official_table(fixture_run, tmp_path):
    # what `run --diagnose` would give, until a run's tally carries the error types itself: the
    # lanes a run saves, scored with --diagnose, add up to the run's own official.csv
    from roneld_eval.api import with_fixture

    result, out = fixture_run
    data = with_fixture(result.config).dataset.data_root
    score = score_culane(data, out / "lanes", workers=1, out=tmp_path / "diagnosed", diagnose=True)
    assert score.diagnosed is not None
    run = pd.read_csv(out / "official.csv", keep_default_na=False)
    frames = pd.read_csv(tmp_path / "diagnosed" / "frames.csv.gz", keep_default_na=False)
    mine = frames.groupby("method")[["tp", "fp", "fn"]].sum().sort_index()
    theirs = run[run["category"] == "all"].set_index("method")[["tp", "fp", "fn"]].sort_index()
    pd.testing.assert_frame_equal(mine, theirs, check_names=False)
