"""Many checkpoints in one `score culane`: roots from a glob or a list file, and sweep.csv/.png
naming the best checkpoint over all frames."""

from __future__ import annotations

import csv
import io
import json
import re

import pytest
from click.testing import CliRunner

from roneld_eval.cli import main
from roneld_eval.sweeps import checkpoint_names, checkpoint_number, expand_roots, natural_key, sweep_table

EPOCHS = (1, 2, 5, 10, 20, 40)


def _invoke(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


@pytest.fixture(scope="module")
def checkpoints(tmp_path_factory):
    """A synthetic CULane set and six checkpoints' lanes, each 30 / epoch px to the right of the
    detector's (later epochs closer)."""
    root = tmp_path_factory.mktemp("sweep")
    result = _invoke("synth", "--dataset", "culane", "--out", root / "set", "--clips", "3", "--frames", "4",
                     "--maps-format", "lanes")
    assert result.exit_code == 0, result.output
    source = root / "set" / "maps"
    for epoch in EPOCHS:
        for path in source.rglob("*.lines.txt"):
            out = root / "ckpt" / f"epoch_{epoch}" / "lines" / path.relative_to(source)
            out.parent.mkdir(parents=True, exist_ok=True)
            lines = []
            for line in path.read_text().splitlines():
                values = line.split()
                lines.append(" ".join(f"{float(x) + 30 / epoch:.2f} {y}" for x, y in zip(values[::2], values[1::2])))
            out.write_text("".join(line + "\n" for line in lines))
    return root


def _rows(path):
    return list(csv.DictReader(io.StringIO(path.read_text())))


def test_a_glob_scores_every_checkpoint_and_the_sweep_names_the_best(checkpoints, tmp_path):
    result = _invoke("score", "culane", "--data-root", checkpoints / "set" / "data", "--pred-root",
                     checkpoints / "ckpt" / "epoch_*" / "lines", "--iou", "0.50:0.95:0.05", "--out", tmp_path / "o")
    assert result.exit_code == 0, result.output
    rows = _rows(tmp_path / "o" / "sweep.csv")
    assert [row["method"] for row in rows] == [f"epoch_{e}" for e in EPOCHS]  # 2 before 10, named by the wildcard
    assert [int(row["checkpoint"]) for row in rows] == list(EPOCHS)
    summary = {row["method"]: row for row in _rows(tmp_path / "o" / "summary.csv") if row["category"] == "all"}
    assert all(row["mF1"] == summary[row["method"]]["mF1"] for row in rows)
    best = max(rows, key=lambda row: float(row["mF1"]))
    assert [row["method"] for row in rows if row["best"] == "True"] == [best["method"]]
    assert f"best by mF1 over all frames: {best['method']}" in result.output
    assert (tmp_path / "o" / "sweep.png").read_bytes().startswith(b"\x89PNG")


def test_a_list_file_names_the_roots(checkpoints, tmp_path):
    listing = checkpoints / "ckpt" / "roots.txt"
    listing.write_text("# name=folder, relative to this file\nlate=epoch_40/lines\n\nepoch_2/lines\n")
    result = _invoke("score", "culane", "--data-root", checkpoints / "set" / "data", "--pred-roots-from", listing,
                     "--out", tmp_path / "o", "--quiet")
    assert result.exit_code == 0, result.output
    assert [row["method"] for row in _rows(tmp_path / "o" / "sweep.csv")] == ["late", "epoch_2"]  # as a glob's
    listing.write_text("=nothing\n")
    result = _invoke("score", "culane", "--data-root", checkpoints / "set" / "data", "--pred-roots-from", listing)
    assert result.exit_code == 2 and f"{listing}:1:" in result.output


def test_checkpoints_are_named_alike_from_a_glob_or_a_list_file(checkpoints, tmp_path):
    # A glob named a checkpoint epoch_12, --pred-roots-from named the same folder epoch_12/lines
    # (or, absolute, "lines": every checkpoint alike, a clash).
    data = checkpoints / "set" / "data"
    result = _invoke("score", "culane", "--data-root", data, "--pred-root", checkpoints / "ckpt" / "epoch_*" / "lines",
                     "--out", tmp_path / "glob", "--quiet")
    assert result.exit_code == 0, result.output
    named = [row["method"] for row in _rows(tmp_path / "glob" / "sweep.csv")]
    assert named == [f"epoch_{e}" for e in EPOCHS]
    relative, absolute = checkpoints / "ckpt" / "relative.txt", tmp_path / "absolute.txt"
    relative.write_text("".join(f"epoch_{e}/lines\n" for e in EPOCHS))
    absolute.write_text("".join(f"{checkpoints / 'ckpt' / f'epoch_{e}' / 'lines'}/\n" for e in EPOCHS))
    for listing in (relative, absolute):
        out = tmp_path / listing.stem
        result = _invoke("score", "culane", "--data-root", data, "--pred-roots-from", listing, "--out", out, "--quiet")
        assert result.exit_code == 0, result.output
        assert [row["method"] for row in _rows(out / "sweep.csv")] == named
        assert (out / "sweep.csv").read_bytes() == (tmp_path / "glob" / "sweep.csv").read_bytes()
    # several seeds' epochs, given both ways at once: what tells them apart, seed and epoch
    seed2 = checkpoints / "seed2"  # beside ckpt/
    seed2.mkdir(exist_ok=True)
    if not (seed2 / "epoch_40").exists():
        (seed2 / "epoch_40").symlink_to(checkpoints / "ckpt" / "epoch_40")
    result = _invoke("score", "culane", "--data-root", data, "--pred-root", seed2 / "epoch_*" / "lines",
                     "--pred-roots-from", absolute, "--out", tmp_path / "both", "--quiet")
    assert result.exit_code == 0, result.output
    assert sorted(row["method"] for row in _rows(tmp_path / "both" / "sweep.csv")) == sorted(
        [f"ckpt/epoch_{e}" for e in EPOCHS] + ["seed2/epoch_40"])


def test_several_named_methods_are_methods_not_a_sweep(checkpoints, tmp_path):
    # `--pred-root ours=A --pred-root theirs=B` was announced as a checkpoint sweep ("best by F1@50
    # over all frames: ours (sweep.csv, sweep.png in OUT)") and compare took its folder for one.
    data = checkpoints / "set" / "data"
    result = _invoke("score", "culane", "--data-root", data, "--pred-root",
                     f"ours={checkpoints / 'ckpt' / 'epoch_40' / 'lines'}", "--pred-root",
                     f"theirs={checkpoints / 'ckpt' / 'epoch_1' / 'lines'}", "--out", tmp_path / "o")
    assert result.exit_code == 0, result.output
    assert "best by" not in result.output and "sweep" not in result.output, result.output
    assert sorted(p.name for p in (tmp_path / "o").iterdir() if not p.name.startswith(".")) == \
        ["official.csv", "summary.csv", "summary.md"]
    assert {row["method"] for row in _rows(tmp_path / "o" / "summary.csv")} == {"ours", "theirs"}
    result = _invoke("compare", tmp_path / "o", "--out", tmp_path / "c")
    assert result.exit_code == 2 and "only as a checkpoint sweep" in result.output, result.output


def test_a_pattern_matching_nothing_or_no_root_at_all_is_refused(checkpoints, tmp_path):
    result = _invoke("score", "culane", "--data-root", checkpoints / "set" / "data", "--pred-root",
                     checkpoints / "ckpt" / "epoch_9*" / "lines")
    assert result.exit_code == 2 and "no folder matches this pattern" in result.output
    result = _invoke("score", "culane", "--data-root", checkpoints / "set" / "data")
    assert result.exit_code == 2 and "--pred-roots-from" in result.output


def test_names_and_order():
    assert sorted(["e10", "e9", "e100"], key=natural_key) == ["e9", "e10", "e100"]
    assert checkpoint_number("seed3/epoch_12") == 12 and checkpoint_number("final") is None
    table, best = sweep_table(["b", "a"], ["F1"], {"a": [0.5], "b": [0.5]})
    assert [row[0] for row in table.rows] == ["b", "a"] and best == "b"  # unnumbered: as given; ties: the first
    assert expand_roots(["x=y", "plain"]) == ["x=y", "plain"]
    assert checkpoint_names(["w/e1/lines", "w/e2/lines", "w/s3/e2/lines"]) == {
        "w/e1/lines": "e1", "w/e2/lines": "e2", "w/s3/e2/lines": "s3/e2"}
    assert checkpoint_names(["w/e1/lines"]) == {"w/e1/lines": "lines"}  # nothing to tell apart: its folder's name
    assert checkpoint_names(["w/e1", "w/e1/more"]) == {"w/e1": "e1", "w/e1/more": "e1/more"}


def test_a_linked_root_is_named_by_the_link_not_its_target(checkpoints, tmp_path):
    (tmp_path / "links").mkdir()
    for name in ("best", "last"):
        (tmp_path / "links" / name).symlink_to(checkpoints / "ckpt" / "epoch_40" / "lines")
    result = _invoke("score", "culane", "--data-root", checkpoints / "set" / "data", "--pred-root",
                     tmp_path / "links" / "best", "--pred-root", tmp_path / "links" / "last", "--out", tmp_path / "o",
                     "--quiet")
    assert result.exit_code == 0, result.output  # both targets are called "lines": named so, they would clash
    assert list(dict.fromkeys(row["method"] for row in _rows(tmp_path / "o" / "summary.csv"))) == ["best", "last"]
    result = _invoke("score", "culane", "--data-root", checkpoints / "set" / "data", "--pred-root",
                     tmp_path / "links" / "*", "--out", tmp_path / "s", "--quiet")
    assert result.exit_code == 0, result.output  # a sweep of the links: the same names
    assert [row["method"] for row in _rows(tmp_path / "s" / "sweep.csv")] == ["best", "last"]


def test_globs_of_several_wildcards_and_folders_named_with_equals_signs(checkpoints, tmp_path):
    for seed in (1, 2):
        for lr in ("0.1", "0.01"):
            (tmp_path / "runs" / f"seed{seed}" / f"lr={lr}").mkdir(parents=True)
            (tmp_path / "runs" / f"seed{seed}" / f"lr={lr}" / "lines").symlink_to(
                checkpoints / "ckpt" / "epoch_40" / "lines")
    result = _invoke("score", "culane", "--data-root", checkpoints / "set" / "data", "--pred-root",
                     tmp_path / "runs" / "seed*" / "lr=*" / "lines", "--out", tmp_path / "o", "--quiet")
    assert result.exit_code == 0, result.output
    names = [row["method"] for row in _rows(tmp_path / "o" / "sweep.csv")]
    assert sorted(names) == ["seed1/lr=0.01", "seed1/lr=0.1", "seed2/lr=0.01", "seed2/lr=0.1"]


def _sweep(checkpoints, out, *extra, pattern="epoch_*", data=None):
    result = _invoke("score", "culane", "--data-root", data or checkpoints / "set" / "data", "--pred-root",
                     checkpoints / "ckpt" / pattern / "lines", "--iou", "0.50:0.95:0.05", "--quiet", "--out", out,
                     *extra)
    assert result.exit_code == 0, result.output
    return out


def test_compare_puts_sweeps_side_by_side_and_names_each_ones_best(checkpoints, tmp_path):
    every, early = _sweep(checkpoints, tmp_path / "every"), _sweep(checkpoints, tmp_path / "early", pattern="epoch_?")
    result = _invoke("compare", every, early, "--label", f"{early}=first epochs", "--out", tmp_path / "c")
    assert result.exit_code == 0, result.output
    assert "2 sweeps compared" in result.output
    rows = _rows(tmp_path / "c" / "sweeps.csv")
    assert [(r["sweep"], r["method"]) for r in rows] == [("every", f"epoch_{e}") for e in EPOCHS] + \
        [("first epochs", f"epoch_{e}") for e in (1, 2, 5)]
    own = {r["method"]: r for r in _rows(tmp_path / "every" / "sweep.csv")}
    best = next(r["method"] for r in own.values() if r["best"] == "True")
    assert best in ("epoch_20", "epoch_40")  # the closest lanes: the latest epochs (the first on a tie)
    assert [r["method"] for r in rows if r["best"] == "True"] == [best, "epoch_5"]
    assert all(float(r["mF1"]) == float(own[r["method"]]["mF1"]) for r in rows[:len(EPOCHS)])  # read, not redone
    table = (tmp_path / "c" / "sweeps.md").read_text()
    assert f"| every | 6 | {best} |" in table and "| first epochs | 3 | epoch_5 |" in table
    assert "12 frames, lanes 30 px wide, IoU 0.50..0.95 (10 thresholds)" in table
    assert (tmp_path / "c" / "sweeps.png").read_bytes().startswith(b"\x89PNG")


def test_sweeps_of_other_frames_or_a_run_beside_a_sweep_are_refused(checkpoints, tmp_path):
    every = _sweep(checkpoints, tmp_path / "every")
    import shutil

    data = tmp_path / "data"  # the same frames, one of them in another category
    shutil.copytree(checkpoints / "set" / "data", data)
    splits = sorted((data / "list" / "test_split").iterdir())
    moved = splits[0].read_text().splitlines()[0]
    splits[0].write_text("".join(line + "\n" for line in splits[0].read_text().splitlines()[1:]))
    splits[1].write_text(splits[1].read_text() + moved + "\n")
    fewer = _sweep(checkpoints, tmp_path / "fewer", data=data)
    result = _invoke("compare", every, fewer, "--out", tmp_path / "c")
    assert result.exit_code == 2 and "differ in their frames" in result.output and "--allow-mixed" in result.output
    assert not (tmp_path / "c" / "sweeps.csv").exists()
    result = _invoke("compare", every, fewer, "--out", tmp_path / "c", "--allow-mixed")
    assert result.exit_code == 0 and "compared anyway (--allow-mixed)" in (tmp_path / "c" / "sweeps.md").read_text()
    run = _invoke("run", "--quiet", "--out", tmp_path / "run")
    assert run.exit_code == 0, run.output
    result = _invoke("compare", every, tmp_path / "run", "--out", tmp_path / "d")
    assert result.exit_code == 2 and "compare runs, or sweeps, not both" in result.output


@pytest.mark.parametrize("edit, said", [
    (lambda folder: (folder / "sweep.json").unlink(), "sweep.json: missing"),
    (lambda folder: (folder / "sweep.csv").write_text((folder / "sweep.csv").read_text().replace("True", "False")),
     "its best checkpoint (none) is not sweep.json's (epoch_"),
    (lambda folder: (folder / "sweep.csv").write_text((folder / "sweep.csv").read_text().replace(",0.", ",1.")),
     "a score outside [0, 1]"),
    # read last-wins before; a RecursionError's traceback before
    (lambda folder: (folder / "sweep.json").write_text((folder / "sweep.json").read_text().replace(
        '"frames":', '"frames": 1, "frames":', 1)), "sweep.json: key 'frames' appears twice in one object"),
    (lambda folder: (folder / "sweep.json").write_text("[" * 100_000 + "]" * 100_000),
     "sweep.json: not JSON roneld-eval wrote: maximum recursion depth exceeded"),
    # a KeyError's traceback before
    (lambda folder: (folder / "sweep.json").write_text(json.dumps(
        {k: v for k, v in json.loads((folder / "sweep.json").read_text()).items() if k != "best"})),
     "sweep.json: its 'best' is missing"),
    # every score NaN but a checkpoint still marked best: max() of nothing's traceback before
    (lambda folder: (folder / "sweep.csv").write_text(re.sub(r",[01]\.\d+(?:e-?\d+)?", ",nan",
                                                             (folder / "sweep.csv").read_text())),
     "the checkpoint marked best is not the one of the highest"),
])
def test_an_edited_sweep_is_named_with_its_problem(checkpoints, tmp_path, edit, said):
    every = _sweep(checkpoints, tmp_path / "every")
    edit(every)
    result = _invoke("compare", every, "--out", tmp_path / "c")
    assert result.exit_code == 2 and said in result.output and len(result.output.strip().splitlines()) == 1, \
        result.output


def test_a_best_among_a_runs_lanes_says_what_ego_lanes_only_means(fixture_run, tmp_path):
    # `score culane --pred-root RUN/lanes` named the baseline best by F1 over all lanes, of which
    # RONELD outputs the two ego lanes alone: read as RONELD losing.
    from roneld_eval.api import fixture_roots

    _, run = fixture_run
    data, _ = fixture_roots("culane")
    result = _invoke("score", "culane", "--data-root", data, "--pred-root", run / "lanes" / "*")
    assert result.exit_code == 0, result.output
    assert "best by F1@50 over all frames: baseline" in result.output
    assert ("note: roneld and roneld-nopft output the two ego lanes only: F1 over all lanes counts the outer lanes "
            "as missed") in result.output
    only = _invoke("score", "culane", "--data-root", data, "--pred-root", f"a={run / 'lanes' / 'roneld'}",
                   "--pred-root", f"b={run / 'lanes' / 'baseline'}")
    assert only.exit_code == 0 and "note:" not in only.output, only.output  # named as the user chose
    methods = _invoke("score", "culane", "--data-root", data, "--pred-root", run / "lanes")
    assert methods.exit_code == 0 and "best by" not in methods.output, methods.output  # methods, not checkpoints


def test_the_sweep_figure_says_what_ego_lanes_only_means(monkeypatch, tmp_path):
    import matplotlib.pyplot as plt

    from roneld_eval.sweeps import plot_sweep, sweep_table

    drawn = []
    monkeypatch.setattr(plt, "close", drawn.append)
    for methods, said in ((["baseline", "roneld"], True), (["epoch_2", "epoch_10"], False)):
        table, _ = sweep_table(methods, ["F1@50"], {method: [0.8 - 0.1 * k] for k, method in enumerate(methods)})
        plot_sweep(table, tmp_path / "sweep.png", "title")
        legend = " ".join(" ".join(text.get_text().split()) for text in drawn[-1].axes[0].get_legend().get_texts())
        assert ("roneld outputs the two ego lanes only: F1 over all lanes counts the outer lanes as missed"
                in legend) == said, legend
