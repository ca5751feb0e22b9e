"""`score culane` and `score tusimple`: grids and mF1, several methods in one pass, wrong
prediction roots, and the two TuSimple F1 formulas against the tools that define them."""

import gzip
import json
import math
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from conftest import GOLDEN, env_importing
from hypothesis import given, settings
from hypothesis import strategies as st
from tusimple_perturbation import digest, perturbed_predictions

from roneld_eval.cli import main
from roneld_eval.errors import ConfigError, InputError
from roneld_eval.metrics.lane_iou_f1 import FrameMatches, ScoredFrames, highlight_name, sum_counts, sweep_rows
from roneld_eval.benchmarks.tusimple.official import TusimpleScore, f1_clrnet, f1_ufld
from roneld_eval.report.tables import Table
from roneld_eval.benchmarks.culane.score import SCORE_PRESETS, first_threshold_table, score_culane
from roneld_eval.benchmarks.tusimple.score import score_tusimple
from roneld_eval.scoring import PlainTable
from roneld_eval.benchmarks.culane.synth import synth_lane_files

GRID = "0.50:0.95:0.05"
LABELS = ["0.50", "0.55", "0.60", "0.65", "0.70", "0.75", "0.80", "0.85", "0.90", "0.95"]


@pytest.fixture(scope="module")
def lanes(tmp_path_factory):
    """Ground truth and noisy predictions of 120 frames, with two category lists."""
    gt, pred = synth_lane_files(tmp_path_factory.mktemp("lanes"), frames=120, seed=3)
    listed = [line.lstrip("/") for line in (gt / "list" / "test.txt").read_text().split()]
    (gt / "list" / "test_split").mkdir()
    (gt / "list" / "test_split" / "test0_normal.txt").write_text("".join(f"{r} \n" for r in listed[:70]))
    (gt / "list" / "test_split" / "test1_curve.txt").write_text("".join(f"{r} \n" for r in listed[70:]))
    return gt, pred


def invoke(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


# ---- grids, mF1 ------------------------------------------------------------------------------


def test_each_threshold_equals_its_own_run_and_mf1_is_their_mean(lanes):
    gt, pred = lanes
    grid = score_culane(gt, pred, iou=GRID, workers=1)
    assert grid.official["threshold"].unique().tolist() == LABELS
    assert grid.official["category"].unique().tolist() == ["normal", "curve", "all"]
    for label in LABELS:
        alone = score_culane(gt, pred, iou=label, workers=1).official
        rows = grid.official[grid.official["threshold"] == label].reset_index(drop=True)
        pd.testing.assert_frame_equal(rows, alone)
    for category in ("normal", "curve", "all"):
        f1 = grid.official[grid.official["category"] == category]["f1"].to_numpy()
        row = grid.summary[grid.summary["category"] == category].iloc[0]
        assert row["mF1"] == np.mean(f1)
        assert row["F1@50"] == f1[0] and row["F1@75"] == f1[5]
    assert 0 < grid.summary["mF1"].min() < grid.summary["F1@50"].min()  # the grid is harder than 0.5


def test_preset_clrnet_is_that_grid_with_50_and_75_highlighted(lanes):
    gt, pred = lanes
    preset = score_culane(gt, pred, preset="clrnet", workers=1)
    grid = score_culane(gt, pred, iou=GRID, workers=1)
    pd.testing.assert_frame_equal(preset.official, grid.official)
    pd.testing.assert_frame_equal(preset.summary, grid.summary)
    assert preset.highlighted == ("0.50", "0.75")
    assert list(preset.summary.columns) == ["method", "category", "F1@50", "F1@75", "mF1"]
    with pytest.raises(ConfigError, match="contradicts --iou 0.3"):
        score_culane(gt, pred, preset="clrnet", iou="0.3", workers=1)
    assert score_culane(gt, pred, preset="clrnet", iou="0.5:0.95:0.05", workers=1).highlighted == ("0.50", "0.75")


def test_a_single_threshold_or_another_grid_highlights_what_it_has(lanes):
    gt, pred = lanes
    single = score_culane(gt, pred, workers=1)  # default 0.5
    assert list(single.summary.columns) == ["method", "category", "F1@50"]  # no mean of one value
    sweep = score_culane(gt, pred, iou="0.30:0.45:0.05", workers=1)
    assert list(sweep.summary.columns) == ["method", "category", "F1@30", "mF1"]  # the first, when neither


def test_highlight_names():
    assert [highlight_name(t) for t in ("0.50", "0.75", "0.5", "0.525", "0.10")] == \
        ["F1@50", "F1@75", "F1@50", "F1@52.5", "F1@10"]


# ---- several methods in one pass ---------------------------------------------------------------


def test_a_folder_of_method_folders_scores_each_in_one_pass(lanes, tmp_path):
    gt, pred = lanes
    shutil.copytree(pred, tmp_path / "lanes" / "noisy")
    shutil.copytree(gt, tmp_path / "lanes" / "perfect", ignore=shutil.ignore_patterns("list"))
    (tmp_path / "lanes" / "notes").mkdir()  # not a prediction tree: left out, said so
    notes = []
    both = score_culane(gt, tmp_path / "lanes", iou=GRID, workers=2, announce=notes.append)
    assert both.methods == ("noisy", "perfect")
    assert any("notes: not a prediction tree" in note for note in notes)
    alone = score_culane(gt, pred, iou=GRID, workers=1).official
    noisy = both.official[both.official["method"] == "noisy"].reset_index(drop=True)
    pd.testing.assert_frame_equal(noisy.drop(columns="method"), alone.drop(columns="method"))
    perfect = both.official[both.official["method"] == "perfect"]
    assert (perfect["fp"] == 0).all() and (perfect["fn"] == 0).all()
    assert set(both.official["method"]) == {"noisy", "perfect"} and len(both.official) == 2 * 3 * 10


def test_several_roots_named_by_folder_or_name(lanes, tmp_path):
    gt, pred = lanes
    score = score_culane(gt, [pred, f"truth={gt}"], workers=1)
    assert score.methods == ("pred", "truth")
    assert score.summary.set_index("method").loc["truth", "F1@50"].tolist() == [1.0, 1.0, 1.0]
    with pytest.raises(ConfigError, match="two prediction trees are named 'pred'.*NAME=DIR"):
        score_culane(gt, [pred, pred], workers=1)
    assert score_culane(gt, {"a": pred, "b": pred}, workers=1).methods == ("a", "b")


def test_the_same_numbers_with_any_number_of_workers(lanes, tmp_path):
    gt, pred = lanes
    for workers in (1, 2):
        result = invoke("score", "culane", "--data-root", gt, "--pred-root", pred, "--pred-root", f"again={pred}",
                        "--preset", "clrnet", "--workers", workers, "--out", tmp_path / f"w{workers}", "--quiet")
        assert result.exit_code == 0, result.output
    for name in ("official.csv", "summary.csv", "summary.md"):
        assert (tmp_path / "w1" / name).read_bytes() == (tmp_path / "w2" / name).read_bytes()


# ---- wrong prediction roots --------------------------------------------------------------------


def test_a_root_one_level_too_low_names_the_path_and_the_folder_that_matches(lanes):
    gt, pred = lanes
    low = pred / "driver_x_30frame"
    with pytest.raises(InputError) as error:
        score_culane(gt, low, workers=1)
    message = str(error.value)
    assert "\n" not in message and message.startswith(f"{low}: no prediction file of the list is here")
    assert f"first looked for: {low}/driver_x_30frame/00000.MP4/00000.lines.txt" in message
    assert message.endswith(f"did you mean --pred-root {pred} (it holds them)?")


def test_a_run_folder_suggests_its_folder_of_methods(lanes, tmp_path):
    gt, pred = lanes
    shutil.copytree(pred, tmp_path / "run" / "lanes" / "roneld")
    result = invoke("score", "culane", "--data-root", gt, "--pred-root", tmp_path / "run", "--quiet")
    assert result.exit_code == 2 and result.output.count("\n") == 1
    lanes_folder = tmp_path / "run" / "lanes"
    assert f"did you mean --pred-root {lanes_folder} (its subfolders roneld each hold them)?" in result.output


def test_a_root_without_any_match_says_what_it_looked_for(lanes, tmp_path):
    gt, _ = lanes
    (tmp_path / "empty" / "sub").mkdir(parents=True)
    result = invoke("score", "culane", "--data-root", gt, "--pred-root", tmp_path / "empty")
    assert result.exit_code == 2 and result.output.count("\n") == 1
    assert "no prediction file of the list is here (first looked for:" in result.output
    assert "did you mean" not in result.output


def test_fewer_than_half_is_a_warning_and_strict_an_error(lanes, tmp_path):
    gt, pred = lanes
    sparse = tmp_path / "sparse"
    shutil.copytree(pred, sparse)
    files = sorted(sparse.rglob("*.lines.txt"))
    for path in files[: len(files) - 40]:
        path.unlink()
    result = invoke("score", "culane", "--data-root", gt, "--pred-root", sparse, "--quiet", "--workers", 1)
    assert result.exit_code == 0
    assert f"warning: {sparse}: only 40 of 120 listed frames have a prediction file" in result.output
    result = invoke("score", "culane", "--data-root", gt, "--pred-root", sparse, "--strict", "--workers", 1)
    assert result.exit_code == 2 and result.output.count("\n") == 1
    assert "80 of 120 listed frames have no prediction file (first: " in result.output and "--strict" in result.output
    # synth_lane_files leaves out 4% of the prediction files: no warning, but not --strict.
    assert score_culane(gt, pred, workers=1).warnings == ()
    with pytest.raises(InputError, match="--strict needs every one"):
        score_culane(gt, pred, workers=1, strict=True)


def test_a_dangling_link_in_a_prediction_root_is_named_not_scored_as_no_lanes(lanes, tmp_path):
    gt, pred = lanes
    copy = tmp_path / "pred"
    shutil.copytree(pred, copy)
    target = sorted(copy.rglob("*.lines.txt"))[5]
    target.unlink()
    target.symlink_to(tmp_path / "gone.lines.txt")
    result = invoke("score", "culane", "--data-root", gt, "--pred-root", copy, "--quiet", "--workers", 1)
    assert result.exit_code == 2 and result.output.count("\n") == 1, result.output
    assert f"{target}: a link to nothing (its target does not exist)" in result.output


def test_width_one_is_refused_not_scored_as_width_two(lanes):
    # The C++ evaluator draws width 1 as a thin 8-connected line (291 px for a real lane where
    # the thick-line rasteriser gives 843): a width the rasteriser does not draw as OpenCV does
    # must not give a number.
    gt, pred = lanes
    result = invoke("score", "culane", "--data-root", gt, "--pred-root", pred, "--width", 1, "--quiet")
    assert result.exit_code == 2 and "--width" in result.output
    with pytest.raises(ConfigError, match="lane width must be at least 2, got 1"):
        score_culane(gt, pred, width=1, workers=1)
    assert score_culane(gt, pred, width=2, workers=1).official["tp"].sum() > 0


def test_a_predicted_coordinate_beyond_float32_integers_is_named(lanes, tmp_path):
    gt, pred = lanes
    copy = tmp_path / "pred"
    shutil.copytree(pred, copy)
    target = sorted(copy.rglob("*.lines.txt"))[3]
    target.write_text("100 590 200 400 300 300 \n410 590 3000000000 400 420 300 \n")
    result = invoke("score", "culane", "--data-root", gt, "--pred-root", copy, "--quiet", "--workers", 1)
    assert result.exit_code == 2 and result.output.count("\n") == 1, result.output
    assert f"{target}:2: point (3000000000, 400) lies more than 2^24 px (16,777,216) from the image origin" \
        in result.output
    target.write_text("100 590 200 400 300 300 \n410 590 16777216 400 420 300 \n")  # the bound itself is scored
    assert invoke("score", "culane", "--data-root", gt, "--pred-root", copy, "--quiet", "--workers", 1).exit_code == 0


def _scoring_command(tmp_path, benchmark: str) -> tuple[list, Path]:
    """A small set of `benchmark` and the command that scores it, with its one prediction root."""
    if benchmark == "vil100":
        golden = GOLDEN / "vil100"
        sizes = json.loads((golden / "test_sizes.json").read_text())
        root = tmp_path / "vil"
        for sequence in sorted(sizes)[:2]:
            for part in ("anno_txt", "pred_txt"):
                shutil.copytree(golden / part / sequence, root / part / sequence)
        (root / "sizes.json").write_text(json.dumps(sizes))
        return (["score", "vil100", "--labels", root / "anno_txt", "--pred-root", root / "pred_txt", "--sizes",
                 root / "sizes.json"], root / "pred_txt")
    extra = ["--maps-format", "lanes"] if benchmark == "culane" else []
    result = invoke("synth", "--dataset", benchmark, "--out", tmp_path / "set", "--clips", 2, "--frames", 3, *extra)
    assert result.exit_code == 0, result.output
    if benchmark == "culane":
        return ["score", "culane", "--data-root", tmp_path / "set" / "data", "--pred-root",
                tmp_path / "set" / "maps"], tmp_path / "set" / "maps"
    command = next(line.split("roneld-eval ", 1)[1] for line in result.output.splitlines()
                   if "roneld-eval score" in line)
    return command.split(), tmp_path / "set" / "predictions"


@pytest.mark.parametrize("benchmark", ["culane", "vil100", "openlane", "curvelanes", "llamas"])
@pytest.mark.parametrize("removed", ["root", "file"])
def test_a_prediction_root_or_file_removed_while_scoring_is_an_error_naming_it(tmp_path, monkeypatch, benchmark,
                                                                                removed):
    # A clean-up script removing old checkpoints while `score culane --pred-root 'ck/epoch_*'` ran:
    # the removed epoch was scored F1 0, exit 0, its summary.md saying every frame had a file.
    import importlib

    args, root = _scoring_command(tmp_path, benchmark)
    scorer = importlib.import_module(f"roneld_eval.benchmarks.{benchmark}.score")
    looked = scorer.find_prediction_trees
    suffix = {"openlane": ".json", "curvelanes": ".lines.json"}.get(benchmark, ".lines.txt")
    victim = root if removed == "root" else sorted(root.rglob(f"*{suffix}"))[-1]

    def then_removed(*given, **options):  # the command has looked: the root goes before it scores
        found = looked(*given, **options)
        shutil.rmtree(victim) if victim.is_dir() else victim.unlink()
        return found

    monkeypatch.setattr(scorer, "find_prediction_trees", then_removed)
    result = invoke(*args, "--workers", 1, "--quiet", "--out", tmp_path / "scores")
    assert result.exit_code == 2 and result.output.count("\n") == 1, result.output
    assert result.output.startswith(f"error: {victim}: this prediction {removed} was removed while the command "
                                    "scored it"), result.output
    assert not (tmp_path / "scores").exists()  # nothing written


# ---- the command line ------------------------------------------------------------------------


def test_the_console_shows_the_summary_and_the_files_hold_everything(lanes, tmp_path):
    gt, pred = lanes
    result = invoke("score", "culane", "--data-root", gt, "--pred-root", pred, "--preset", "clrnet",
                    "--workers", 1, "--out", tmp_path / "o")
    assert result.exit_code == 0, result.output
    assert "120 frames, 1 method, IoU thresholds 0.50, 0.55, ..., 0.95 (10 thresholds), width 30" in result.output
    assert "| method | category | F1@50 | F1@75 | mF1 |" in result.output
    official = pd.read_csv(tmp_path / "o" / "official.csv", dtype={"threshold": str})
    assert list(official.columns) == ["method", "category", "threshold", "tp", "fp", "fn", "precision", "recall", "f1"]
    assert len(official) == 3 * 10 and official["threshold"].unique().tolist() == LABELS
    summary = pd.read_csv(tmp_path / "o" / "summary.csv")
    all_row = summary[summary["category"] == "all"].iloc[0]
    assert f"| pred | all | {100 * all_row['F1@50']:.2f} | {100 * all_row['F1@75']:.2f} | " in result.output
    text = (tmp_path / "o" / "summary.md").read_text()
    assert "mF1 is the mean F1 over those thresholds" in text and "| pred | curve |" in text
    assert sorted(p.name for p in (tmp_path / "o").iterdir() if not p.name.startswith(".")) == \
        ["official.csv", "summary.csv", "summary.md"]


@pytest.mark.parametrize("command", ["culane", "tusimple"])
def test_a_foreign_out_is_refused_before_any_scoring(lanes, tmp_path, monkeypatch, command):
    import roneld_eval.benchmarks.tusimple.official as tusimple_official
    import roneld_eval.benchmarks.culane.score as scoring

    def no_work(*args, **kwargs):
        raise AssertionError("scored before the output folder was checked")

    monkeypatch.setattr(scoring, "_score_frames", no_work)
    monkeypatch.setattr(tusimple_official, "read_labels", no_work)
    out = tmp_path / "thesis"
    out.mkdir()
    (out / "thesis.tex").write_text("mine")
    gt, pred = lanes
    if command == "culane":
        args = ["score", "culane", "--data-root", gt, "--pred-root", pred, "--workers", 1, "--out", out]
    else:
        (tmp_path / "labels.json").write_text("")
        args = ["score", "tusimple", "--labels", tmp_path / "labels.json", "--pred", tmp_path / "labels.json",
                "--out", out]
    result = invoke(*args)
    assert result.exit_code == 2 and result.output.count("\n") == 1, result.output
    assert "holds files roneld-eval did not write (thesis.tex)" in result.output
    assert [p.name for p in out.iterdir()] == ["thesis.tex"]


def test_a_show_folder_in_a_score_folder_is_roneld_evals_own_not_foreign(lanes, fixture_run, tmp_path):
    # `show --run RUN --out SCORES/show` beside a score's files made the next score into SCORES
    # refuse the folder as holding "files roneld-eval did not write (show)".
    gt, pred = lanes
    scores = tmp_path / "scores"
    args = ["score", "culane", "--data-root", gt, "--pred-root", pred, "--workers", 1, "--quiet", "--out", scores]
    assert invoke(*args).exit_code == 0
    _, run = fixture_run
    shown = invoke("show", "--run", run, "--worst", 1, "--out", scores / "show")
    assert shown.exit_code == 0, shown.output
    pictures = sorted(p.relative_to(scores) for p in (scores / "show").rglob("*.png"))
    result = invoke(*args)
    assert result.exit_code == 0, result.output
    assert sorted(p.relative_to(scores) for p in (scores / "show").rglob("*.png")) == pictures  # left as they were
    (scores / "notes").mkdir()  # a folder of the user's still is foreign
    result = invoke(*args)
    assert result.exit_code == 2 and "holds files roneld-eval did not write (notes)" in result.output, result.output


def test_the_cli_presets_are_the_librarys():
    command = main.commands["score"].get_command(None, "culane")
    preset = next(p for p in command.params if p.name == "preset")
    assert sorted(preset.type.choices) == sorted(SCORE_PRESETS)


# ---- start-up: the tables without pandas, byte for byte what pandas wrote ----------------------


def pandas_csv(table: PlainTable) -> str:
    """What score culane wrote before it dropped pandas: DataFrame.to_csv with these options (floats
    in pandas' own default text: numpy's shortest repr, the same double read back)."""
    frame = pd.DataFrame(list(table.rows), columns=list(table.columns))
    return frame.to_csv(index=False, lineterminator="\n")


def test_the_files_are_what_pandas_wrote_and_the_frames_what_it_held(tmp_path):
    gt, pred = synth_lane_files(tmp_path, frames=40, seed=4)
    listed = (gt / "list" / "test.txt").read_text()
    (gt / "list" / "test.txt").write_text(listed + "/cross/00000.jpg\n")  # no lanes, no prediction: NaN ratios
    (gt / "cross").mkdir()
    (gt / "cross" / "00000.lines.txt").write_text("")
    (gt / "list" / "test_split").mkdir()
    (gt / "list" / "test_split" / "test0_normal.txt").write_text(listed.replace("/", "", 1)[:400])
    (gt / "list" / "test_split" / "test7_cross.txt").write_text("cross/00000.jpg\n")
    score = score_culane(gt, [f'a "quoted", name={pred}', f"truth={gt}"], iou="0.3:0.9:0.15", workers=1,
                         out=tmp_path / "o")
    official = (tmp_path / "o" / "official.csv").read_text()
    assert official == pandas_csv(score.official_rows) == score.official.to_csv(index=False, lineterminator="\n")
    assert (tmp_path / "o" / "summary.csv").read_text() == pandas_csv(score.summary_rows)
    assert '"a ""quoted"", name",cross,0.30,0,0,0,,,' in official  # minimal quoting, NaN empty
    for frame, plain in ((score.official, score.official_rows), (score.summary, score.summary_rows)):
        as_before = pd.DataFrame([dict(zip(plain.columns, row)) for row in plain.rows], columns=list(plain.columns))
        pd.testing.assert_frame_equal(frame, as_before)  # built from dicts, as sweep_rows and f1_summary did
    # The console's table at the first threshold: what the DataFrame gave, cell for cell, its
    # ratios in percent as summary.md gives them.
    table = score.table
    ratios = {"precision": "precision (%)", "recall": "recall (%)", "f1": "F1 (%)"}
    cells = tuple(tuple(("n/a" if math.isnan(v) else f"{100 * v:.2f}") if c in ratios else str(v)
                        for c, v in zip(table.columns, row)) for row in table.itertuples(index=False))
    columns = tuple(ratios.get(c, c) for c in table.columns)
    assert first_threshold_table(score).to_markdown() == Table(columns, cells).to_markdown()


cell_text = st.text(st.characters(codec="utf-8"), max_size=6) | \
    st.sampled_from(["", ",", '"', "a,b", 'say "hi"', "line\nbreak", "cr\r", " lead", "0.50", "NaN", "n/a"])
cell_number = st.floats(allow_nan=True, allow_infinity=True) | st.sampled_from([0.5, 1 / 3, -0.0, 2.5e-7, 1e300])
cell_count = st.integers(-(2**63), 2**63 - 1)


@st.composite
def plain_tables(draw):
    """A table whose columns each hold one kind of value, as score culane's tables do."""
    kinds = draw(st.lists(st.sampled_from([cell_text, cell_number, cell_count]), min_size=1, max_size=5))
    columns = draw(st.lists(st.text(st.characters(codec="utf-8"), max_size=5), min_size=len(kinds),
                            max_size=len(kinds), unique=True))
    rows = draw(st.lists(st.tuples(*kinds), max_size=6))
    return PlainTable(tuple(columns), tuple(rows))


@settings(max_examples=300, deadline=None)
@given(plain_tables())
def test_plain_csv_is_byte_for_byte_what_pandas_writes(table):
    assert table.to_csv() == pandas_csv(table)


@settings(max_examples=300, deadline=None)
@given(st.floats(allow_nan=False) | st.sampled_from([0.8317773908, 1 / 3, -0.0, 5e-324, 1e16, 1e-5]))
def test_a_float_is_written_as_the_shortest_text_that_reads_back_the_same_double(value):
    # %.6f gave 0.831777 where MMA-Net's evaluate_iou.py prints 0.8317773908...: a number equal to
    # the official one, bit for bit, is written as Python prints it.
    text = PlainTable(("x",), ((value,),)).to_csv().splitlines()[1]
    assert float(text) == value and math.copysign(1, float(text)) == math.copysign(1, value), text
    assert text == repr(value)


def test_score_culane_on_one_frame_starts_without_pandas_or_matplotlib(tmp_path):
    """Start-up (issue 15): these imports cost more than scoring a small set. No timing here,
    scripts/bench_startup.py times it; the extractors' kernels are not loaded either."""
    gt, pred = synth_lane_files(tmp_path, frames=1, seed=0)
    program = ("import sys\nfrom roneld_eval.cli import main\ntry:\n    main(sys.argv[1:])\nexcept SystemExit as e:\n"
               "    assert not e.code, e.code\n"
               "print(sorted(m for m in ('pandas', 'matplotlib', 'roneld_eval.extract') if m in sys.modules))")
    env = env_importing()
    done = subprocess.run([sys.executable, "-c", program, "score", "culane", "--data-root", str(gt), "--pred-root",
                           str(pred), "--out", str(tmp_path / "o")], capture_output=True, text=True, env=env)
    assert done.returncode == 0, done.stderr
    assert "| pred | all |" in done.stdout and (tmp_path / "o" / "summary.md").is_file()
    assert done.stdout.splitlines()[-1] == "[]"


# ---- the table arithmetic, as a property -------------------------------------------------------


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.lists(st.sampled_from([-math.inf, 0.0, 0.3, 0.5, 0.55, 0.75, 0.9, 1.0]), max_size=5),
                          st.integers(0, 6), st.booleans()), max_size=12),
       st.lists(st.sampled_from([0.0, 0.3, 0.5, 0.55, 0.75, 0.95]), min_size=1, max_size=4, unique=True))
def test_sweep_rows_count_like_one_pass_per_threshold(frames, thresholds):
    """The sorted, vectorised counts equal summing every frame at each threshold on its own."""
    results = {f"f{k}.jpg": FrameMatches(len(ious), n_pred, np.array(ious, np.float64))
               for k, (ious, n_pred, _) in enumerate(frames)}
    category = {"odd": frozenset(f"f{k}.jpg" for k, (_, _, odd) in enumerate(frames) if odd)}
    table = sweep_rows(ScoredFrames.from_results([results]), ["m"], category, thresholds)
    for name, members in (("odd", category["odd"]), ("all", frozenset(results))):
        chosen = [r for f, r in results.items() if f in members]
        counts = sum_counts(chosen, thresholds)
        rows = table[table["category"] == name]
        assert rows["tp"].tolist() == counts.tp.tolist()
        assert rows["fp"].tolist() == counts.fp.tolist() and rows["fn"].tolist() == counts.fn.tolist()


# ---- TuSimple F1: UFLD-v2's lane2.py and CLRNet's tusimple_metric.py ---------------------------


def test_the_two_f1_formulas_by_hand():
    assert f1_ufld(0.0, 0.0) == 1.0 and f1_clrnet(0.0, 0.0) == 1.0
    # UFLD-v2: precision 1 - FP = 0.9, recall 1 - FN = 0.8.
    assert f1_ufld(0.1, 0.2) == 2 * 0.9 * 0.8 / (0.9 + 0.8)
    # CLRNet: tp = 1 - FP = 0.9, precision 0.9 / (0.9 + 0.1), recall 0.9 / (0.9 + 0.2).
    precision, recall = 0.9 / (0.9 + 0.1), 0.9 / (0.9 + 0.2)
    assert f1_clrnet(0.1, 0.2) == 2 * precision * recall / (precision + recall)
    assert f1_ufld(0.1, 0.2) < f1_clrnet(0.1, 0.2)  # why papers' TuSimple F1s differ
    # Where lane2.py guards (precision + recall = 0) it gives 0; where tusimple_metric.py
    # divides by zero (tp = 0) it stops, and we say NaN.
    assert f1_ufld(1.0, 1.0) == 0.0 and math.isnan(f1_clrnet(1.0, 1.0)) and math.isnan(f1_clrnet(1.0, 0.0))
    score = TusimpleScore(0.95, 0.1, 0.2, 10)
    assert score.as_row() == dict(accuracy=0.95, fp=0.1, fn=0.2,
                                  f1_ufld=f1_ufld(0.1, 0.2), f1_clrnet=f1_clrnet(0.1, 0.2))


def real_tusimple_labels(shared_data: Path, tmp_path: Path) -> Path:
    """The official TuSimple test labels, decompressed into tmp_path (or a clean skip)."""
    labels_gz = shared_data / "tusimple" / "test_label.json.gz"
    if not labels_gz.is_file():
        pytest.skip("tusimple/test_label.json.gz is not available")
    labels = tmp_path / "test_label.json"
    labels.write_bytes(gzip.decompress(labels_gz.read_bytes()))
    return labels


def test_tusimple_f1_equals_both_tools_on_the_full_test_labels(shared_data, tmp_path):
    labels = real_tusimple_labels(shared_data, tmp_path)
    golden = json.loads((GOLDEN / "tusimple_f1.json").read_text())
    lines = labels.read_text().splitlines(keepends=True)
    for case in golden["cases"]:
        text = perturbed_predictions(lines, case["seed"], case["severity"])
        assert digest(text) == case["predictions_sha256"], "the perturbation changed: these are not the golden's inputs"
        pred = tmp_path / f"{case['severity']}.json"
        pred.write_text(text)
        score = score_tusimple(labels, pred)
        ufld, clrnet = case["lane2"], case["tusimple_metric"]
        ours = dict(accuracy=score.accuracy, fp=score.fp, fn=score.fn, f1_ufld=score.f1_ufld, f1_clrnet=score.f1_clrnet)
        theirs = dict(accuracy=ufld["Accuracy"], fp=ufld["FP"], fn=ufld["FN"], f1_ufld=ufld["F1"],
                      f1_clrnet=clrnet["F1_score"])
        assert (clrnet["Accuracy"], clrnet["FP"], clrnet["FN"]) == (ufld["Accuracy"], ufld["FP"], ufld["FN"])
        if ours != theirs:  # a table that explains itself
            pytest.fail(f"{case['severity']}:\n" + "\n".join(f"  {k:10s} ours {ours[k]!r:22} theirs {theirs[k]!r}"
                                                             for k in ours if ours[k] != theirs[k]))
        assert score.n_frames == 2782


def test_tusimple_angle_thresholds_are_numpys_as_lane_py_computes_them(shared_data, tmp_path):
    # Rows of the 9 real lanes whose threshold differs in the last bits between numpy's arctan
    # and cos (lane.py's) and the math module's, moved between the two thresholds.
    labels = real_tusimple_labels(shared_data, tmp_path)
    golden = json.loads((GOLDEN / "tusimple_angle.json").read_text())
    records = [json.loads(line) for line in labels.read_text().splitlines()]
    for i, j, k, value in golden["edits"]:
        records[i]["lanes"][j][k] = value
    text = "".join(json.dumps({"raw_file": r["raw_file"], "lanes": r["lanes"], "h_samples": r["h_samples"],
                               "run_time": 10}) + "\n" for r in records)
    assert digest(text) == golden["predictions_sha256"]
    pred = tmp_path / "pred.json"
    pred.write_text(text)
    score = score_tusimple(labels, pred)
    # lane.py's thresholds are numpy's here: as the math module's where numpy has no SIMD arctan
    # and cos of its own (no AVX-512), else as on the machine the tools ran on for the golden.
    from roneld_eval.metrics.point_accuracy import PIXEL_THRESHOLD, lane_slope, lane_threshold

    truth = [json.loads(line) for line in labels.read_text().splitlines()]
    thresholds = []
    for i, j in sorted({(i, j) for i, j, _, _ in golden["edits"]}):
        xs, ys = np.array(truth[i]["lanes"][j], float), np.array(truth[i]["h_samples"], float)
        thresholds.append((lane_threshold(xs, ys), PIXEL_THRESHOLD / math.cos(math.atan(lane_slope(xs, ys)))))
    ufld, clrnet = golden["lane2"], golden["tusimple_metric"]
    if all(numpy == maths for numpy, maths in thresholds):
        expected = golden["math_module_gives"]  # what lane.py computes on this machine
        assert (score.accuracy, score.fp, score.fn, score.f1_ufld, score.f1_clrnet) == \
            (expected["accuracy"], expected["fp"], expected["fn"], expected["f1_ufld"], expected["f1_clrnet"])
        return
    if not all(numpy != maths for numpy, maths in thresholds):
        pytest.skip("numpy's arctan and cos differ from the math module's for some of the 9 lanes only here: "
                    "the golden has no value for that")
    assert (score.accuracy, score.fp, score.fn, score.f1_ufld, score.f1_clrnet) == \
        (ufld["Accuracy"], ufld["FP"], ufld["FN"], ufld["F1"], clrnet["F1_score"])


def test_score_tusimple_on_every_frame_of_a_clip_says_what_to_do(tmp_path):
    from roneld_eval.benchmarks.tusimple.synth import synth_tusimple

    synth_tusimple(tmp_path / "t", clips=2, seed=1, maps_format="lanes")  # predictions for frames 1..20
    labels, every = tmp_path / "t" / "data" / "test_label.json", tmp_path / "t" / "maps" / "predictions.json"
    result = invoke("score", "tusimple", "--labels", labels, "--pred", every)
    assert result.exit_code == 2 and "1.jpg is not in the labels (test_label.json); its clip is labelled on " \
        "20.jpg only" in result.output, result.output
    scored = tmp_path / "scored.json"
    scored.write_text("".join(line + "\n" for line in every.read_text().splitlines() if '/20.jpg"' in line))
    assert invoke("score", "tusimple", "--labels", labels, "--pred", scored).exit_code == 0


def test_score_tusimple_writes_and_prints_both_f1s(tmp_path):
    rows = list(range(160, 720, 10))
    labels = [{"lanes": [[500] * 56, [800] * 56], "h_samples": rows, "raw_file": f"clips/{k}/20.jpg"} for k in "ab"]
    preds = [{"raw_file": "clips/a/20.jpg", "lanes": [[505] * 56, [800] * 56]},
             {"raw_file": "clips/b/20.jpg", "lanes": [[505] * 56, [100] * 56]}]
    (tmp_path / "labels.json").write_text("".join(json.dumps(x) + "\n" for x in labels))
    (tmp_path / "pred.json").write_text("".join(json.dumps(x) + "\n" for x in preds))
    result = invoke("score", "tusimple", "--labels", tmp_path / "labels.json", "--pred", tmp_path / "pred.json",
                    "--out", tmp_path / "o")
    assert result.exit_code == 0, result.output
    # Frame b: one of two lanes found, one of two predictions false: FP = FN = 0.5 / 2 frames.
    assert ("Accuracy 0.75  FP 0.25  FN 0.25  F1 0.75 (UFLD-v2 lane2.py)  0.75 (CLRNet tusimple_metric.py)"
            in result.output)
    table = (tmp_path / "o" / "official.csv").read_text().splitlines()
    # a method column, as score culane's for one root and a run's TuSimple official.csv
    assert table == ["method,accuracy,fp,fn,f1_ufld,f1_clrnet", "pred,0.75,0.25,0.25,0.75,0.75"]


def test_score_tusimple_scores_several_prediction_files_as_methods_in_one_pass(tmp_path, monkeypatch):
    # `--pred A.json --pred B.json` scored only the last file, and official.csv named no method.
    from roneld_eval.benchmarks.tusimple import official as tusimple_official

    rows = list(range(160, 720, 10))
    labels = [{"lanes": [[500] * 56, [800] * 56], "h_samples": rows, "raw_file": f"clips/{k}/20.jpg"} for k in "ab"]
    preds = [{"raw_file": "clips/b/20.jpg", "lanes": [[505] * 56, [100] * 56]},  # another order than the labels'
             {"raw_file": "clips/a/20.jpg", "lanes": [[505] * 56, [800] * 56]}]
    (tmp_path / "labels.json").write_text("".join(json.dumps(x) + "\n" for x in labels))
    (tmp_path / "mine.json").write_text("".join(json.dumps(x) + "\n" for x in preds))
    (tmp_path / "truth.json").write_text((tmp_path / "labels.json").read_text())
    read, reading = [], tusimple_official.read_labels
    monkeypatch.setattr(tusimple_official, "read_labels", lambda path: read.append(path) or reading(path))
    result = invoke("score", "tusimple", "--labels", tmp_path / "labels.json", "--pred", tmp_path / "mine.json",
                    "--pred", f"gt={tmp_path / 'truth.json'}", "--out", tmp_path / "o")
    assert result.exit_code == 0, result.output
    assert len(read) == 1  # the labels read once for both
    assert (tmp_path / "o" / "official.csv").read_text().splitlines() == [
        "method,accuracy,fp,fn,f1_ufld,f1_clrnet", "mine,0.75,0.25,0.25,0.75,0.75", "gt,1.0,0.0,0.0,1.0,1.0"]
    assert "mine: 2 frames: Accuracy 0.75  FP 0.25" in result.output
    assert "gt: 2 frames: Accuracy 1  FP 0" in result.output
    # the library: one file gives its score, as before; several a score per method, each as scored alone
    alone = {name: score_tusimple(tmp_path / "labels.json", tmp_path / f"{file}.json")
             for name, file in (("mine", "mine"), ("gt", "truth"))}
    assert isinstance(alone["mine"], TusimpleScore) and alone["mine"].accuracy == 0.75
    assert score_tusimple(tmp_path / "labels.json", [tmp_path / "mine.json", f"gt={tmp_path / 'truth.json'}"]) == alone
    assert score_tusimple(tmp_path / "labels.json", {"mine": tmp_path / "mine.json", "gt": tmp_path / "truth.json"}) \
        == alone
    result = invoke("score", "tusimple", "--labels", tmp_path / "labels.json", "--pred", tmp_path / "mine.json",
                    "--pred", tmp_path / "mine.json")
    assert result.exit_code == 2 and "two prediction files are named 'mine'" in result.output \
        and "--pred NAME=FILE" in result.output, result.output
