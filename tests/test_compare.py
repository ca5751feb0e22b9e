"""`roneld-eval compare`: every number in every table is the runs' own, and what is not comparable is refused.

The runs are real `run` outputs on tiny generated datasets: CULane with SCNN (two "seeds": the
second extracts with another baseline threshold) and "ENet-SAD" (the same maps under another
label and baseline threshold), TuSimple with both. The expected cells are computed here from
each run's accuracy.csv, runtime.csv, official.csv and per_frame.csv with pandas, independently
of the reader in roneld_eval/comparison.
"""

from __future__ import annotations

import json
import math
from decimal import ROUND_HALF_UP, Decimal
import re
import shutil
import statistics
import subprocess
import tempfile
from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from roneld_eval import api
from roneld_eval.cli import main
from roneld_eval.comparison import compare, read_run
from roneld_eval.thresholds import Thresholds
from roneld_eval.errors import ConfigError, InputError, RoneldEvalError
from roneld_eval.metrics.bootstrap import paired_bootstrap
from roneld_eval.report.tables import latex_text

EVERY_FILE = ("comparison.csv", "table_accuracy.md", "table_accuracy.tex", "table_ablation.md", "table_ablation.tex",
              "table_runtime.md", "table_runtime.tex", "table_official.md", "table_official.tex", "curves.png",
              "curves.svg", "curves.pdf", "summary.json")
PAIR_FILES = ("pairs.csv", "table_pairs.md", "table_pairs.tex")
DATASET_NAMES = {"culane": "CULane", "tusimple": "TuSimple"}


def evaluate(out: Path, data: Path, maps: Path, dataset: str, **overrides) -> Path:
    config = api.default_config(dataset).with_overrides(**{
        "dataset.data_root": str(data), "maps.root": str(maps), "maps.format": "npy", "workers": 1, **overrides})
    api.run(config, out, progress=False)
    return out


@pytest.fixture(scope="module")
def data(tmp_path_factory) -> dict:
    root = tmp_path_factory.mktemp("compare-data")
    culane = api.synthesize("culane", root / "culane", clips=5, frames=4, seed=1)
    tusimple = api.synthesize("tusimple", root / "tusimple", clips=5, frames=2, seed=2)
    return {"culane": (culane.data_root, culane.maps_root), "tusimple": (tusimple.data_root, tusimple.maps_root),
            "root": root}


@pytest.fixture(scope="module")
def runs(data) -> dict[str, Path]:
    root = data["root"] / "runs"
    return {
        "cu_scnn": evaluate(root / "cu_scnn", *data["culane"], "culane", pft_ablation=True),
        "cu_scnn_b": evaluate(root / "cu_scnn_b", *data["culane"], "culane", pft_ablation=True,
                              **{"baseline.threshold": 0.4}),
        "cu_enet": evaluate(root / "cu_enet", *data["culane"], "culane", pft_ablation=True, model="ENet-SAD",
                            **{"baseline.threshold": 0.5}),
        "ts_scnn": evaluate(root / "ts_scnn", *data["tusimple"], "tusimple", pft_ablation=True),
        "ts_enet": evaluate(root / "ts_enet", *data["tusimple"], "tusimple", model="ENet-SAD",
                            **{"baseline.threshold": 0.5}),
    }


# (dataset, label, run keys): the groups the default labels (config.toml's model) make
GROUPS = [("culane", "SCNN", ["cu_scnn", "cu_scnn_b"]), ("culane", "ENet-SAD", ["cu_enet"]),
          ("tusimple", "SCNN", ["ts_scnn"]), ("tusimple", "ENet-SAD", ["ts_enet"])]


@pytest.fixture(scope="module")
def compared(runs, data):
    out = data["root"] / "compared"
    order = ["cu_scnn", "cu_scnn_b", "cu_enet", "ts_scnn", "ts_enet"]
    result = compare([runs[k] for k in order], out, pairs=[(runs["cu_scnn"], runs["cu_enet"])])
    return result, out


# ---- what a cell should say, from the runs' own files --------------------------------------------

def accuracy_csv(run: Path) -> pd.DataFrame:
    return pd.read_csv(run / "accuracy.csv", dtype={"threshold": str}).set_index(["method", "threshold"])


def fixed(value: float, decimals: int, signed: bool = False) -> str:
    """The tables' rule: halves round up from 12 significant digits, so one number prints alike in
    every table however it was computed."""
    if math.isnan(value):
        return "n/a"
    digits = Decimal(format(float(value), ".12g"))
    text = f"{digits.quantize(Decimal(1).scaleb(-decimals), ROUND_HALF_UP):f}"
    if float(text) == 0:
        text = f"{0.0:.{decimals}f}"
    return "+" + text if signed and not text.startswith("-") else text


def stat(values, decimals: int = 3, scale: float = 1.0, signed: bool = False) -> str:
    values = [v * scale for v in values]
    text = fixed(statistics.fmean(values), decimals, signed)
    if len(values) == 1 or text == "n/a":
        return text
    return text + f" ± {fixed(statistics.stdev(values), decimals)}"


def label_of(threshold: str) -> str:
    return f"{float(threshold):.2f}"


def suffix(n: int) -> str:
    return "" if n == 1 else f" (n = {n})"


def gain_cell(paths: list[Path], threshold: str) -> str:
    label = label_of(threshold)
    tables = [accuracy_csv(p) for p in paths]
    gains = [t.loc[("baseline", label), "roneld_gain"] for t in tables]
    bases = [t.loc[("baseline", label), "accuracy"] for t in tables]
    per_frame = [pd.read_csv(p / "per_frame.csv") for p in paths]
    clips = per_frame[0]["frame"].map(lambda f: f.rsplit("/", 1)[0]).nunique()
    if len(paths) == 1:
        low, high = (tables[0].loc[("baseline", label), c] for c in ("roneld_gain_ci_low", "roneld_gain_ci_high"))
    else:  # seeds share frames: one bootstrap over clips of the pooled counts
        grid = sorted(set(tables[0].index.get_level_values("threshold")))
        interval = paired_bootstrap(pd.concat(per_frame, ignore_index=True),
                                    Thresholds(tuple(grid), tuple(float(g) for g in grid)), "baseline", "roneld")
        row = interval[interval["threshold"] == label].iloc[0]
        low, high = row.ci_low, row.ci_high
    if not math.isnan(low):
        interval_text = f"[{fixed(low, 3)}, {fixed(high, 3)}]"
    else:
        interval_text = f"[n/a ({clips} clip{'s' if clips != 1 else ''})]" if clips < 5 else "[n/a]"
    base = statistics.fmean(bases)
    relative = "n/a" if base == 0 else f"{fixed(statistics.fmean(gains) / base * 100, 1)}%"
    return f"{stat(gains, signed=True)} {interval_text} **({relative})**"


def markdown_tables(text: str) -> list[tuple[str, list[str], list[list[str]]]]:
    """(section heading, headers, rows) of every Markdown table in a file."""
    tables, section, lines = [], "", text.splitlines()
    k = 0
    while k < len(lines):
        line = lines[k]
        if line.startswith("## "):
            section = line[3:].strip()
        if line.startswith("|") and k + 1 < len(lines) and lines[k + 1].startswith("|---"):
            split = lambda row: [cell.strip() for cell in row.strip().strip("|").split("|")]  # noqa: E731
            headers, rows = split(line), []
            k += 2
            while k < len(lines) and lines[k].startswith("|"):
                rows.append(split(lines[k]))
                k += 1
            tables.append((section, headers, rows))
            continue
        k += 1
    return tables


def check_accuracy_tables(out: Path, groups: list[tuple[str, str, list[Path]]], rows=("0.3", "0.4", "0.5")):
    tables = markdown_tables((out / "table_accuracy.md").read_text())
    assert [t[0] for t in tables] == list(dict.fromkeys(DATASET_NAMES[g[0]] for g in groups))
    for section, headers, body in tables:
        members = [g for g in groups if DATASET_NAMES[g[0]] == section]
        expected_headers = ["IoU threshold"]
        for _, label, paths in members:
            n = suffix(len(paths))
            expected_headers += [f"{label}{n}", f"{label} + RONELD{n}", f"Acc. Inc.{n}"]
        assert headers == expected_headers
        assert [r[0] for r in body] == list(rows)
        for row in body:
            threshold, cells = row[0], iter(row[1:])
            for _, label, paths in members:
                tables_ = [accuracy_csv(p) for p in paths]
                for method in ("baseline", "roneld"):
                    assert next(cells) == stat([t.loc[(method, label_of(threshold)), "accuracy"] for t in tables_]), \
                        (section, label, method, threshold)
                assert next(cells) == gain_cell(paths, threshold), (section, label, threshold)


def check_ablation_table(out: Path, groups, rows=("0.3", "0.5")):
    holding = [g for g in groups if "roneld-nopft" in set(accuracy_csv(g[2][0]).index.get_level_values("method"))]
    (_, headers, body), = markdown_tables((out / "table_ablation.md").read_text())
    expected = ["IoU threshold"]
    for dataset, label, paths in holding:
        for short in ("w/o PFT", "w/ PFT"):
            expected.append(f"{DATASET_NAMES[dataset]}, {label} + RONELD {short}{suffix(len(paths))}")
    assert headers == expected
    assert [r[0] for r in body] == list(rows)
    for row in body:
        cells = iter(row[1:])
        for _, _, paths in holding:
            for method in ("roneld-nopft", "roneld"):
                assert next(cells) == stat([accuracy_csv(p).loc[(method, label_of(row[0])), "accuracy"] for p in paths])


def check_runtime_table(out: Path, groups):
    (_, headers, body), = markdown_tables((out / "table_runtime.md").read_text())
    runtime = {p: pd.read_csv(p / "runtime.csv").set_index("method")["mean_ms"] for g in groups for p in g[2]}
    methods = [m for m in ("roneld", "roneld-nopft", "baseline") if any(m in r.index for r in runtime.values())]
    names = {"roneld": "RONELD (ms)", "roneld-nopft": "RONELD w/o PFT (ms)", "baseline": "baseline (ms)"}
    assert headers == ["Dataset", "Model"] + [names[m] for m in methods]
    means = {m: [] for m in methods}
    for row, (dataset, label, paths) in zip(body, groups):
        assert row[:2] == [DATASET_NAMES[dataset], f"{label}{suffix(len(paths))}"]
        for cell, method in zip(row[2:], methods):
            if method not in runtime[paths[0]].index:
                assert cell == "–"
                continue
            values = [runtime[p][method] for p in paths]
            assert cell == stat(values)
            means[method].append(statistics.fmean(values))
    mean_row = body[len(groups)]
    assert mean_row[0] == "Mean" and len(body) == len(groups) + 1
    assert mean_row[2:] == [fixed(statistics.fmean(means[m]), 3) for m in methods]


def check_official_tables(out: Path, groups):
    names = {"baseline": "{}", "roneld": "{} + RONELD", "roneld-nopft": "{} + RONELD w/o PFT"}
    found = markdown_tables((out / "table_official.md").read_text())
    tables = {section: (headers, body) for section, headers, body in found}
    culane = [g for g in groups if g[0] == "culane"]
    if culane:
        headers, body = tables["CULane"]
        official = {p: pd.read_csv(p / "official.csv").set_index(["method", "category"]) for g in culane for p in g[2]}
        columns = []
        for _, label, paths in culane:
            methods = list(dict.fromkeys(official[paths[0]].index.get_level_values("method")))
            columns += [(names[m].format(label) + suffix(len(paths)), m, paths) for m in methods]
        assert headers == ["Category"] + [c[0] for c in columns]
        categories = list(dict.fromkeys(official[culane[0][2][0]].index.get_level_values("category")))
        categories = [c for c in categories if c not in ("all", "ego")] + ["all", "ego"]
        assert [r[0] for r in body] == [("cross (FP)" if c == "cross" else c) for c in categories]
        for row, category in zip(body, categories):
            for cell, (_, method, paths) in zip(row[1:], columns):
                if category == "cross":
                    assert cell == stat([official[p].loc[(method, category), "fp"] for p in paths], decimals=0)
                else:
                    assert cell == stat([official[p].loc[(method, category), "f1"] for p in paths], 1, 100)
    tusimple = [g for g in groups if g[0] == "tusimple"]
    if tusimple:
        headers, body = tables["TuSimple"]
        assert headers == ["Method", "Accuracy (%)", "FP", "FN", "F1 (%)"]
        rows = iter(body)
        for _, label, paths in tusimple:
            official = [pd.read_csv(p / "official.csv").set_index("method") for p in paths]
            for method in official[0].index:
                row = next(rows)
                assert row[0] == names[method].format(label) + suffix(len(paths))
                fp = [o.loc[method, "fp"] for o in official]
                fn = [o.loc[method, "fn"] for o in official]
                f1 = [o.loc[method, "f1_clrnet"] for o in official]  # the run's own, never recomputed
                assert row[1:] == [stat([o.loc[method, "accuracy"] for o in official], 2, 100), stat(fp, 4),
                                   stat(fn, 4), stat(f1, 2, 100)]
        assert next(rows, None) is None


def check_comparison_csv(out: Path, groups):
    table = pd.read_csv(out / "comparison.csv", dtype=str, keep_default_na=False)
    assert list(table.columns) == ["run", "label", "dataset", "model", "method", "threshold", "n_tp", "n_gt",
                                   "accuracy"]
    for dataset, label, paths in groups:
        for path in paths:
            own = pd.read_csv(path / "accuracy.csv", dtype=str, keep_default_na=False)
            mine = table[table["run"] == str(path)]
            assert set(mine["label"]) == {label} and set(mine["dataset"]) == {dataset}
            for column in ("method", "threshold", "n_tp", "n_gt", "accuracy"):
                assert list(mine[column]) == list(own[column]), (path, column)


NUMBER = re.compile(r"[-+]?\d+(?:\.\d+)?")


def body_numbers_md(text: str) -> list[str]:
    """Numbers in the body cells (the first column, repeated in each LaTeX block, apart)."""
    return sorted(n for _, _, rows in markdown_tables(text) for row in rows for cell in row[1:]
                  for n in NUMBER.findall(cell))


def body_numbers_tex(text: str) -> list[str]:
    numbers, inside = [], False
    for line in text.splitlines():
        if line.strip() == "\\midrule":
            inside = True
        elif line.strip() == "\\bottomrule":
            inside = False
        elif inside and not line.strip().startswith("\\addlinespace"):
            cells = line.replace("$-$", "-").split("&")[1:]
            numbers += [n for cell in cells for n in NUMBER.findall(cell)]
    return sorted(numbers)


def check_latex_matches_markdown(out: Path):
    for md in sorted(out.glob("table_*.md")):
        tex = md.with_suffix(".tex")
        assert body_numbers_tex(tex.read_text()) == body_numbers_md(md.read_text()), md.name
        # a quoted method name in TeX's quotes: two straight ones print as two closing quotes
        assert not re.search(r"(?<!\w)'[\w-]+'", tex.read_text()), tex.name
    ablation = out / "table_ablation.tex"
    if ablation.exists():
        assert "`roneld-nopft'" in ablation.read_text()


def check_everything(out: Path, groups):
    check_accuracy_tables(out, groups)
    check_runtime_table(out, groups)
    check_official_tables(out, groups)
    check_comparison_csv(out, groups)
    if (out / "table_ablation.md").exists():
        check_ablation_table(out, groups)
    check_latex_matches_markdown(out)


# ---- the tables -------------------------------------------------------------------------------

def test_compare_writes_every_file(compared):
    result, out = compared
    for name in EVERY_FILE + PAIR_FILES:
        assert (out / name).is_file() and (out / name).stat().st_size > 0, name
    assert len(result.runs) == 5


def test_every_number_in_every_table_is_the_runs_own(compared, runs):
    _, out = compared
    check_everything(out, [(d, label, [runs[k] for k in keys]) for d, label, keys in GROUPS])


def test_pairs_are_a_paired_bootstrap_over_clips(compared, runs):
    _, out = compared
    pairs = pd.read_csv(out / "pairs.csv", dtype={"threshold": str})
    a, b = runs["cu_scnn"], runs["cu_enet"]
    assert set(pairs["a"]) == {str(a)} and set(pairs["b"]) == {str(b)}
    per_a, per_b = pd.read_csv(a / "per_frame.csv"), pd.read_csv(b / "per_frame.csv")
    grid = sorted(set(pairs["threshold"]))
    thresholds = Thresholds(tuple(grid), tuple(float(g) for g in grid))
    for method in ("baseline", "roneld", "roneld-nopft"):
        both = pd.concat([per_a[per_a["method"] == method].assign(method="a"),
                          per_b[per_b["method"] == method].assign(method="b")])
        expected = paired_bootstrap(both, thresholds, "a", "b")
        mine = pairs[pairs["method"] == method].reset_index(drop=True)
        assert list(mine["threshold"]) == list(expected["threshold"])
        for column in ("difference", "ci_low", "ci_high"):
            assert mine[column].to_numpy() == pytest.approx(expected[column].to_numpy(), abs=1e-9)
        acc_a, acc_b = accuracy_csv(a), accuracy_csv(b)
        for row in mine.itertuples():
            assert row.accuracy_a == pytest.approx(acc_a.loc[(method, row.threshold), "accuracy"])
            assert row.difference == pytest.approx(acc_b.loc[(method, row.threshold), "accuracy"] - row.accuracy_a)
    (_, headers, body), = markdown_tables((out / "table_pairs.md").read_text())
    assert headers == ["Runs", "Method", "IoU > 0.3", "IoU > 0.4", "IoU > 0.5"]
    words = {"baseline": "baseline", "roneld": "RONELD", "roneld-nopft": "RONELD w/o PFT"}
    assert [row[:2] for row in body] == [["ENet-SAD − SCNN (cu_scnn)", words[m]] for m in words]
    for row, method in zip(body, words):
        for cell, threshold in zip(row[2:], ("0.30", "0.40", "0.50")):
            hit = pairs[(pairs["method"] == method) & (pairs["threshold"] == threshold)].iloc[0]
            relative = "n/a" if hit.accuracy_a == 0 else f"{fixed(hit.difference / hit.accuracy_a * 100, 1)}%"
            assert cell == (f"{fixed(hit.difference, 3, signed=True)} [{fixed(hit.ci_low, 3)}, "
                            f"{fixed(hit.ci_high, 3)}] **({relative})**"), (method, threshold)


def test_labels_override_and_thresholds_pick_rows(runs, tmp_path):
    out = tmp_path / "out"
    compare([runs["cu_scnn"], runs["cu_enet"]], out, labels={str(runs["cu_scnn"]): "Mine", runs["cu_enet"]: "Theirs"},
            thresholds="0.35,0.45")
    (_, headers, body), = markdown_tables((out / "table_accuracy.md").read_text())
    assert headers[1:4] == ["Mine", "Mine + RONELD", "Acc. Inc."] and headers[4] == "Theirs"
    assert [r[0] for r in body] == ["0.35", "0.45"]
    check_accuracy_tables(out, [("culane", "Mine", [runs["cu_scnn"]]), ("culane", "Theirs", [runs["cu_enet"]])],
                          rows=("0.35", "0.45"))
    (_, _, ablation), = markdown_tables((out / "table_ablation.md").read_text())
    assert [r[0] for r in ablation] == ["0.35", "0.45"]
    assert set(pd.read_csv(out / "comparison.csv")["label"]) == {"Mine", "Theirs"}


def test_seeds_show_mean_and_sd_with_n(compared):
    _, out = compared
    text = (out / "table_accuracy.md").read_text()
    assert "SCNN (n = 2)" in text and " ± " in text and "sample standard deviation over the n runs" in text
    tex = (out / "table_accuracy.tex").read_text()
    assert "SCNN, n = 2" in tex and "$\\pm$" in tex


def test_figure_has_no_title_and_names_its_axes(compared):
    _, out = compared
    svg = (out / "curves.svg").read_text()
    assert "IoU threshold" in svg and "accuracy (N_TP / N_gt)" in svg
    assert "Ego-lane accuracy" not in svg
    for name in ("CULane", "TuSimple", "ENet-SAD + RONELD", "SCNN + RONELD (mean ± sd, n = 2 CULane, 1 TuSimple)"):
        assert name in svg, name


def test_same_inputs_give_the_same_bytes(runs, tmp_path):
    paths = [runs["cu_scnn"], runs["ts_scnn"]]
    compare(paths, tmp_path / "a")
    compare(paths, tmp_path / "b")
    for file in sorted((tmp_path / "a").iterdir()):
        assert file.read_bytes() == (tmp_path / "b" / file.name).read_bytes(), file.name


def test_other_method_names_are_rows_and_curves_of_their_own(runs, tmp_path):
    """A plug-in extractor's method is shown under its own name; 'roneld-nopft' alone makes Table IV."""
    plug = tmp_path / "plug"
    shutil.copytree(runs["cu_scnn"], plug)
    for name in ("accuracy.csv", "per_frame.csv", "runtime.csv", "official.csv"):
        path = plug / name
        path.write_text(path.read_text().replace("roneld-nopft", "polyfit"))
    out = tmp_path / "out"
    compare([plug], out)
    (_, headers, body), = markdown_tables((out / "table_accuracy.md").read_text())
    assert headers == ["IoU threshold", "SCNN", "SCNN + RONELD", "Acc. Inc.", "SCNN polyfit"]
    own = accuracy_csv(runs["cu_scnn"])
    assert [r[4] for r in body] == [fixed(own.loc[("roneld-nopft", label_of(t)), "accuracy"], 3)
                                    for t in ("0.3", "0.4", "0.5")]
    assert not (out / "table_ablation.md").exists()
    assert "polyfit" in (out / "table_runtime.md").read_text() and "polyfit" in (out / "curves.svg").read_text()
    assert "SCNN polyfit" in (out / "table_official.md").read_text()


# ---- what is not comparable --------------------------------------------------------------------

def test_tusimple_f1_is_the_runs_own_even_where_it_is_n_a(runs, tmp_path):
    # fp = 1, fn = 0.5: CLRNet's script divides by zero (tp = 0), so the run writes an empty
    # f1_clrnet; recomputing it gave 0.0 beside the run's n/a.
    run = tmp_path / "run"
    shutil.copytree(runs["ts_scnn"], run)
    official = pd.read_csv(run / "official.csv", dtype=str, keep_default_na=False)
    assert official.loc[0, "method"] == "baseline"
    official.loc[0, ["fp", "fn", "f1_clrnet"]] = ["1", "0.5", ""]
    official.to_csv(run / "official.csv", index=False)
    compare([run], tmp_path / "out")
    text = (tmp_path / "out" / "table_official.md").read_text()
    cells = next(line for line in text.splitlines() if line.startswith("| SCNN |")).split("|")[1:-1]
    assert [cell.strip() for cell in cells[2:]] == ["1.0000", "0.5000", "n/a"]


@pytest.mark.parametrize("value", ["-1", "0.9"])
def test_an_edited_tusimple_f1_is_refused(value, runs, tmp_path):
    run = tmp_path / "run"
    shutil.copytree(runs["ts_scnn"], run)
    official = pd.read_csv(run / "official.csv", dtype=str, keep_default_na=False)
    official.loc[0, "f1_clrnet"] = value
    official.to_csv(run / "official.csv", index=False)
    with pytest.raises(InputError, match=f"official.csv:2: f1_clrnet {value} is not CLRNet's F1 of fp "):
        compare([run], tmp_path / "out")


def test_different_frames_are_refused(runs, data, tmp_path):
    fewer = evaluate(tmp_path / "fewer", *data["culane"], "culane", **{"dataset.limit": 3})
    with pytest.raises(ConfigError, match="both are CULane runs but scored different frames"):
        compare([runs["cu_scnn"], fewer], tmp_path / "out")
    assert not (tmp_path / "out").exists()


def test_different_ground_truth_is_refused(runs, tmp_path):
    other = tmp_path / "other"
    shutil.copytree(runs["cu_enet"], other)
    summary = json.loads((other / "summary.json").read_text())
    summary["counts"]["gt_lanes"] += 1
    (other / "summary.json").write_text(json.dumps(summary))
    with pytest.raises(ConfigError, match="against different ground truth"):
        compare([runs["cu_scnn"], other], tmp_path / "out")


def test_different_threshold_grids_are_refused(runs, data, tmp_path):
    coarse = evaluate(tmp_path / "coarse", *data["culane"], "culane", **{"paper.thresholds": "0.30:0.50:0.05"})
    with pytest.raises(ConfigError, match=r"different IoU threshold grids \(0.30..0.50 step 0.01, 21 thresholds "
                                          r"and 0.30..0.50 step 0.05, 5 thresholds\)"):
        compare([runs["cu_scnn"], coarse], tmp_path / "out")


def test_different_protocols_need_allow_mixed_and_then_say_so(runs, data, tmp_path):
    height = evaluate(tmp_path / "height", *data["culane"], "culane", model="ENet-SAD",
                      **{"paper.thickness_rule": "height"})
    with pytest.raises(ConfigError, match="paper.thickness_rule = 'width' and 'height'.*--allow-mixed"):
        compare([runs["cu_scnn"], height], tmp_path / "out")
    result = compare([runs["cu_scnn"], height, runs["ts_scnn"]], tmp_path / "out", allow_mixed=True)
    assert result.notes and "paper.thickness_rule" in result.notes[0]
    for name in ("table_accuracy", "table_ablation", "table_runtime", "table_official"):
        for suffix_ in (".md", ".tex"):
            text = (tmp_path / "out" / f"{name}{suffix_}").read_text()
            assert "Compared with" in text and "allow-mixed" in text and "thickness" in text, name + suffix_


@pytest.mark.parametrize("make, message", [
    (lambda p: None, "not found: give a folder written by `roneld-eval run`"),
    (lambda p: p.mkdir(), "it has no run manifest"),
    (lambda p: (p.mkdir(), (p / "notes.txt").write_text("x")), "it has no run manifest"),
])
def test_a_folder_that_is_not_a_finished_run_is_refused(make, message, runs, tmp_path):
    folder = tmp_path / "folder"
    make(folder)
    result = CliRunner().invoke(main, ["compare", str(runs["cu_scnn"]), str(folder), "--out", str(tmp_path / "out")])
    assert result.exit_code == 2 and message in result.output and "Traceback" not in result.output
    assert result.output.startswith(f"error: {folder}")


def test_a_killed_run_and_another_commands_folder_are_refused(runs, data, tmp_path):
    scores = tmp_path / "scores"
    api.score_tusimple(Path(data["tusimple"][0]) / "test_label.json", Path(data["tusimple"][0]) / "test_label.json",
                       out=scores)
    with pytest.raises(InputError, match="`roneld-eval score tusimple` wrote it"):
        compare([scores], tmp_path / "out")
    killed = tmp_path / "killed"
    shutil.copytree(runs["cu_scnn"], killed)
    (killed / ".roneld-commit.json").write_text("{}")
    with pytest.raises(InputError, match="incomplete"):
        compare([killed], tmp_path / "out")


def test_control_characters_in_a_label_are_refused_and_never_reach_latex(runs, tmp_path):
    with pytest.raises(ConfigError, match="a label must not hold control characters"):
        compare([runs["cu_scnn"]], tmp_path / "out", labels={runs["cu_scnn"]: "SCNN\x07\x1b[31m"})
    copy = tmp_path / "copy"
    shutil.copytree(runs["cu_scnn"], copy)
    config = (copy / "config.toml").read_text()
    (copy / "config.toml").write_text(config.replace('model = "SCNN"', 'model = "SCNN\\u001b[31m"', 1))
    with pytest.raises(InputError, match="`model` holds control characters"):
        compare([copy], tmp_path / "out")
    assert latex_text("a\x07b\tc\x9b") == "a?b c?"


def test_a_damaged_manifest_of_an_input_run_names_the_right_remedy(runs, tmp_path):
    # It said "remove the folder or choose another --out", of a run given as input.
    broken = tmp_path / "broken"
    shutil.copytree(runs["cu_scnn"], broken)
    with open(broken / ".roneld-run.json", "wb") as handle:
        handle.truncate(10 * 10**9)
    for args in (["compare", str(broken), "--out", str(tmp_path / "out")], ["show", "--run", str(broken)]):
        result = CliRunner().invoke(main, args)
        assert result.exit_code == 2 and "not a manifest this tool wrote" in result.output, result.output
        assert "give a folder `roneld-eval run` wrote" in result.output and "--out" not in result.output


def test_out_may_not_lie_inside_a_compared_run(runs, tmp_path):
    # compare --out RUN/cmp made the run's folder hold files `run` did not write.
    copy = tmp_path / "copy"
    shutil.copytree(runs["cu_scnn"], copy)
    result = CliRunner().invoke(main, ["compare", str(copy), "--out", str(copy / "cmp")])
    assert result.exit_code == 2 and "lies inside the run folder" in result.output, result.output
    assert not (copy / "cmp").exists()


def test_a_foreign_out_is_refused_before_any_run_is_read(runs, tmp_path, monkeypatch):
    import roneld_eval.comparison as comparison

    def no_work(*args, **kwargs):
        raise AssertionError("read a run before the output folder was checked")

    monkeypatch.setattr(comparison, "read_run", no_work)
    out = tmp_path / "thesis"
    out.mkdir()
    (out / "thesis.tex").write_text("mine")
    result = CliRunner().invoke(main, ["compare", str(runs["cu_scnn"]), "--out", str(out)])
    assert result.exit_code == 2 and "did not write (thesis.tex)" in result.output, result.output


def test_out_may_not_be_a_run_folder(runs, tmp_path):
    copy = tmp_path / "copy"
    shutil.copytree(runs["cu_scnn"], copy)
    with pytest.raises(InputError, match="holds the results of `roneld-eval run`"):
        compare([runs["cu_enet"]], copy)


@pytest.mark.parametrize("name, content, message", [
    ("accuracy.csv", "method,threshold\nbaseline,0.30\n", "accuracy.csv: has no column n_tp, n_gt, accuracy"),
    ("accuracy.csv", "method,threshold,n_tp,n_gt,accuracy\nbaseline,0.30,3,x,0.5\n",
     "accuracy.csv:2: column n_gt: 'x' is not a whole number in [0, 2^53]"),
    ("accuracy.csv", "method,threshold,n_tp,n_gt,accuracy\nbaseline,0.30,1e308,1e308,1\n",
     "accuracy.csv:2: column n_tp: '1e308' is not a whole number in [0, 2^53]"),
    ("accuracy.csv", "method,threshold,n_tp,n_gt,accuracy\nbaseline,0.30,3,4,0.5\n",
     "accuracy.csv:2: accuracy 0.5 is not n_tp / n_gt = 3 / 4"),
    ("accuracy.csv", "method,threshold,n_tp,n_gt,accuracy\nbaseline,1.5,3,4,0.75\n",
     "accuracy.csv:2: threshold '1.5' is not an IoU threshold in [0, 1)"),
    ("accuracy.csv", "\"unclosed\n", "accuracy.csv: not a valid CSV table"),
    ("accuracy.csv", b"\xff\xfe\x00bad", "accuracy.csv: not UTF-8 text"),
    ("accuracy.csv", "", "accuracy.csv: empty"),
    ("per_frame.csv", "frame,side,method,iou\na/b.jpg,left,baseline,1.7\n",
     "per_frame.csv:2: IoU 1.7 is outside [0, 1]"),
    ("per_frame.csv", "frame,side,method,iou\na/b.jpg,left,baseline,0.7\n",
     "per_frame.csv: holds 1 lanes of method baseline, but accuracy.csv counts"),
    ("runtime.csv", "method,frames\nroneld,3\n", "runtime.csv: has no column mean_ms"),
    ("official.csv", "method,category,tp,fp,fn,f1\nroneld,all,1,2,3,inf\n",
     "official.csv:2: column f1: 'inf' is not a number or empty"),
    ("config.toml", "model = \n", "config.toml: not valid TOML"),
    ("config.toml", "model = 3\n", "config.toml: `model` is missing or not a str"),
    ("config.toml", "a = " + "[" * 100_000 + "]" * 100_000 + "\n",
     "config.toml: not TOML this tool wrote: nested too deeply"),
    ("summary.json", "{\"counts\": ", "summary.json: not valid JSON"),
    ("summary.json", "[]", "summary.json: must hold a JSON object"),
    ("summary.json", "{\"counts\": {\"clips\": -1}}", "summary.json: `counts` must hold clips"),
])
def test_a_malformed_file_is_one_line_naming_it(name, content, message, runs, tmp_path):
    broken = tmp_path / "broken"
    shutil.copytree(runs["cu_scnn"], broken)
    if isinstance(content, bytes):
        (broken / name).write_bytes(content)
    else:
        (broken / name).write_text(content)
    result = CliRunner().invoke(main, ["compare", str(broken), "--out", str(tmp_path / "out")])
    assert result.exit_code == 2, result.output
    assert result.output.startswith("error: ") and len(result.output.strip().splitlines()) == 1
    assert f"{broken}/{message}" in result.output
    assert "Traceback" not in result.output
    assert not (tmp_path / "out").exists()


def test_a_key_given_twice_in_summary_json_is_refused_naming_it(runs, tmp_path):
    # json.loads kept the last "dataset" and compared the run as what it held last
    broken = tmp_path / "broken"
    shutil.copytree(runs["cu_scnn"], broken)
    text = (broken / "summary.json").read_text()
    (broken / "summary.json").write_text(text.replace('"dataset":', '"dataset": "tusimple", "dataset":', 1))
    result = CliRunner().invoke(main, ["compare", str(broken), "--out", str(tmp_path / "out")])
    assert result.exit_code == 2, result.output
    assert result.output == f"error: {broken}/summary.json: key 'dataset' appears twice in one object (JSON " \
                            "readers differ on which one counts): give it once\n"
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("name", ["per_frame.csv", "accuracy.csv"])
def test_a_huge_run_table_is_refused_unread(name, runs, tmp_path):
    # compare of a run whose per_frame.csv is 4 GB gave no answer in 120 s.
    broken = tmp_path / "broken"
    shutil.copytree(runs["cu_scnn"], broken)
    with open(broken / name, "wb") as handle:
        handle.truncate(4 * 10**9)
    result = CliRunner().invoke(main, ["compare", str(broken), "--out", str(tmp_path / "out")])
    assert result.exit_code == 2 and result.output.count("\n") == 1, result.output
    assert f"{broken / name}: too large (4,000,000,000 bytes): a run's table" in result.output
    if name == "per_frame.csv":  # what show reads
        result = CliRunner().invoke(main, ["show", "--run", str(broken), "--out", str(tmp_path / "pictures")])
        assert result.exit_code == 2 and "too large" in result.output, result.output


@pytest.fixture(scope="module")
def pristine(runs, tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("pristine") / "run"
    shutil.copytree(runs["cu_scnn"], folder)
    return folder


MUTATED = ("accuracy.csv", "per_frame.csv", "runtime.csv", "official.csv", "config.toml", "summary.json",
           ".roneld-run.json")


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(name=st.sampled_from(MUTATED), position=st.floats(0, 1), cut=st.booleans(),
       insert=st.binary(min_size=0, max_size=12))
def test_any_damaged_file_gives_an_input_error_never_a_traceback(pristine, name, position, cut, insert):
    with tempfile.TemporaryDirectory() as scratch:
        folder = Path(scratch) / "run"
        shutil.copytree(pristine, folder)
        data = (folder / name).read_bytes()
        at = int(position * len(data))
        (folder / name).write_bytes(data[:at] + insert + (b"" if cut else data[at + len(insert):]))
        try:
            read_run(folder)
        except RoneldEvalError as error:
            assert str(error).strip() and "\n" not in str(error)


# ---- labels, pairs and the command line -----------------------------------------------------------

def test_command_line(runs, tmp_path):
    out = tmp_path / "out"
    result = CliRunner().invoke(main, ["compare", str(runs["cu_scnn"]), str(runs["cu_enet"]), "--out", str(out),
                                       "--label", f"{runs['cu_enet']}=ENet-SAD (ours)",
                                       "--pair", "SCNN,ENet-SAD (ours)"])
    assert result.exit_code == 0, result.output
    assert "| IoU threshold | SCNN | SCNN + RONELD | Acc. Inc. | ENet-SAD (ours) |" in result.output
    assert (out / "table_pairs.md").is_file()


@pytest.mark.parametrize("extra, message", [
    (["--label", "nowhere=X"], "--label nowhere=X: nowhere is not one of the run folders compared"),
    (["--label", "X"], "--label X: write RUN=LABEL"),
    (["--pair", "SCNN"], "--pair SCNN: name two runs"),
    (["--pair", "SCNN,Nobody"], "Nobody is neither a run folder compared, nor a run's label, nor the name of a "
                                "run's folder"),
    (["--thresholds", "0.335"], "--thresholds: 0.335 is not among the runs' thresholds (0.30..0.50 step 0.01"),
    (["--thresholds", "0.3:0.5"], "thresholds '0.3:0.5' must be"),
])
def test_bad_options_are_one_line(extra, message, runs, tmp_path):
    result = CliRunner().invoke(main, ["compare", str(runs["cu_scnn"]), str(runs["cu_enet"]),
                                       "--out", str(tmp_path / "out")] + extra)
    assert result.exit_code == 2, result.output
    assert message in result.output and "Traceback" not in result.output


def test_two_labels_for_one_run_are_refused_not_the_last_kept(runs, tmp_path):
    run = runs["cu_enet"]
    for other in (str(run), f"{run}/."):  # the same folder, spelled alike or not
        result = CliRunner().invoke(main, ["compare", str(runs["cu_scnn"]), str(run), "--out", str(tmp_path / "out"),
                                           "--label", f"{run}=ENet-SAD", "--label", f"{other}=ENet"])
        assert result.exit_code == 2, result.output
        assert "has the label 'ENet-SAD' already; give each run one --label" in result.output
        assert not (tmp_path / "out").exists()
    result = CliRunner().invoke(main, ["compare", str(runs["cu_scnn"]), str(run), "--out", str(tmp_path / "out"),
                                       "--label", f"{run}=ENet-SAD", "--label", f"{run}= ENet-SAD "])
    assert result.exit_code == 0, result.output  # the same label twice says the same


def test_a_pair_may_name_runs_by_their_folders_own_names(runs, tmp_path):
    # A first-time user's `--pair culane,culane2` (the folders' names, not their paths) was refused.
    a, b = runs["cu_scnn"], runs["cu_enet"]
    assert a.name != b.name
    result = CliRunner().invoke(main, ["compare", str(a), str(b), "--out", str(tmp_path / "out"), "--pair",
                                       f"{a.name},{b.name}"])
    assert result.exit_code == 0, result.output
    assert (tmp_path / "out" / "table_pairs.md").is_file()


def test_pairs_need_one_run_each_on_the_same_frames(runs, tmp_path):
    with pytest.raises(ConfigError, match="SCNN names 2 runs; name one by its folder"):
        compare([runs["cu_scnn"], runs["cu_scnn_b"]], tmp_path / "out", pairs=["SCNN,SCNN"])
    with pytest.raises(ConfigError, match="not scored on the same frames"):
        compare([runs["cu_scnn"], runs["ts_scnn"]], tmp_path / "out", pairs=[(runs["cu_scnn"], runs["ts_scnn"])])
    with pytest.raises(ConfigError, match="is given twice"):
        compare([runs["cu_scnn"], runs["cu_scnn"]], tmp_path / "out")


def test_seeds_must_run_the_same_methods(runs, data, tmp_path):
    plain = evaluate(tmp_path / "plain", *data["culane"], "culane")
    with pytest.raises(ConfigError, match="ran different methods"):
        compare([runs["cu_scnn"], plain], tmp_path / "out")
    compare([runs["cu_scnn"], plain], tmp_path / "out", labels={plain: "SCNN w/o ablation"})


# ---- LaTeX in a two-column paper --------------------------------------------------------------------

def compile_tables(folder: Path, tmp_path: Path) -> str:
    """pdflatex's log of a two-column article holding every table of `folder`."""
    inputs = "\n".join(f"\\input{{{path}}}\n\\clearpage" for path in sorted(folder.glob("table_*.tex")))
    document = tmp_path / "paper.tex"
    document.write_text("\\documentclass[twocolumn]{article}\n\\usepackage{booktabs}\n\\begin{document}\n"
                        "Results.\n" + inputs + "\n\\end{document}\n")
    run = subprocess.run(["pdflatex", "-interaction=nonstopmode", "-halt-on-error", document.name], cwd=tmp_path,
                         capture_output=True, text=True, timeout=120)
    log = (tmp_path / "paper.log").read_text(errors="replace")
    assert run.returncode == 0, log[-3000:]
    return log


def test_latex_tables_compile_in_a_two_column_paper_without_overfull_boxes(compared, runs, tmp_path):
    if shutil.which("pdflatex") is None:
        pytest.skip("pdflatex is not installed")
    _, out = compared
    log = compile_tables(out, tmp_path)
    assert "Overfull \\hbox" not in log
    # Many models with long names: the wide tables stack blocks of columns instead of running off the page.
    copies = []
    names = ["SCNN", "ENet-SAD", "SCNN-ResNet101 (ours)", "LaneATT ResNet-34 fine-tuned", "UFLD_v2 & friends_#1",
             "PolyLaneNet 100% of data"]
    for k in range(len(names)):
        copy = tmp_path / f"copy{k}"
        shutil.copytree(runs["cu_scnn"], copy)
        copies.append(copy)
    many = tmp_path / "many"
    compare(copies + [runs["ts_scnn"], runs["ts_enet"]], many, labels={c: n for c, n in zip(copies, names)},
            pairs=[(copies[0], copies[1])])
    (tmp_path / "many-paper").mkdir()
    log = compile_tables(many, tmp_path / "many-paper")
    assert "Overfull \\hbox" not in log
    assert (many / "table_accuracy.tex").read_text().count("\\begin{tabular}") >= 3


def test_an_ablation_of_two_models_fits_where_it_says(runs, tmp_path):
    """Its spanning model names are what make it wide: a `table` must fit one column with them."""
    from roneld_eval.comparison.tables import COLUMN_GAP_PT, NARROW_PT, text_pt

    out = tmp_path / "two"
    result = CliRunner().invoke(main, ["compare", str(runs["cu_scnn"]), str(runs["cu_enet"]), "--out", str(out)])
    assert result.exit_code == 0, result.output
    tex = (out / "table_ablation.tex").read_text()
    names = re.findall(r"\\multicolumn\{2\}\{c\}\{([^}]*)\}", tex)
    assert names == ["CULane, SCNN + RONELD", "CULane, ENet-SAD + RONELD"]
    if "\\begin{table}" in tex:
        assert text_pt("threshold") + sum(text_pt(name) + COLUMN_GAP_PT for name in names) <= NARROW_PT
    else:
        assert "\\begin{table*}" in tex and "spanning both columns" in tex
    if shutil.which("pdflatex") is not None:
        assert "Overfull \\hbox" not in compile_tables(out, tmp_path)


# ---- the real clip ---------------------------------------------------------------------------------

def test_real_clip_as_two_models(real_clip_tree, tmp_path):
    data, maps = real_clip_tree
    runner = CliRunner()
    runs = {}
    for model, extra in (("SCNN", []), ("ENet-SAD", ["--set", "baseline.threshold=0.5"])):
        out = tmp_path / model
        result = runner.invoke(main, ["run", "--config", "scnn-culane", "--data-root", str(data), "--maps-root",
                                      str(maps), "--maps-format", "scnn-png", "--pft-ablation", "--quiet",
                                      "--workers", "1", "--set", f"model={model}", "--out", str(out)] + extra)
        assert result.exit_code == 0, result.output
        runs[model] = out
    out = tmp_path / "compared"
    result = runner.invoke(main, ["compare", str(runs["SCNN"]), str(runs["ENet-SAD"]), "--out", str(out),
                                  "--pair", "SCNN,ENet-SAD", "--quiet"])
    assert result.exit_code == 0, result.output
    for name in EVERY_FILE + PAIR_FILES:
        assert (out / name).is_file(), name
    check_everything(out, [("culane", "SCNN", [runs["SCNN"]]), ("culane", "ENet-SAD", [runs["ENet-SAD"]])])
    assert "[n/a (1 clip)]" in (out / "table_accuracy.md").read_text()  # one video: no interval


@pytest.mark.parametrize("command", ["compare", "show", "score"])
def test_sigterm_while_working_is_one_line_and_leaves_nothing(command, runs, tmp_path, monkeypatch):
    # score and compare handled SIGTERM only while writing their files: earlier, it ended the
    # process at once, without the line run prints.
    import os
    import signal

    import roneld_eval.api as api_module
    import roneld_eval.comparison as comparison
    import roneld_eval.benchmarks.culane.score as scoring

    def terminated(*args, **kwargs):
        os.kill(os.getpid(), signal.SIGTERM)
        raise AssertionError("the signal did not interrupt")

    out = tmp_path / "out"
    run = runs["cu_scnn"]
    if command == "compare":
        monkeypatch.setattr(comparison, "read_run", terminated)
        args = ["compare", str(run), "--out", str(out)]
    elif command == "show":
        monkeypatch.setattr(api_module, "_show_pictures", terminated)
        args = ["show", "--run", str(run), "--out", str(out)]
    else:
        monkeypatch.setattr(scoring, "find_prediction_trees", terminated)
        config = (run / "config.toml").read_text()
        data_root = next(line for line in config.splitlines() if line.startswith("data_root")).split('"')[1]
        args = ["score", "culane", "--data-root", data_root, "--pred-root", str(run / "lanes"), "--out", str(out)]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 128 + signal.SIGTERM, result.output
    assert result.output.strip() == "terminated (SIGTERM): no result was written"
    assert not out.exists()


@pytest.mark.parametrize("models", [1, 2, 4, 6])
@pytest.mark.parametrize("datasets", [["CULane"], ["CULane", "TuSimple"]])
def test_the_legend_lies_inside_the_figure(models, datasets, tmp_path):
    # With one dataset the legend of three methods was wider than its one panel, cut off on
    # both sides of curves.png.
    from roneld_eval.comparison.figure import Curve, curves_figure
    from roneld_eval.report.figure_files import write_png

    thresholds = tuple(k / 100 for k in range(30, 51))
    suffix = {"baseline": "", "roneld": " + RONELD", "roneld-nopft": " + RONELD w/o PFT"}
    curves = [Curve(dataset, f"Model-{m} ResNet-34", method, f"Model-{m} ResNet-34{suffix[method]}", thresholds,
                    (tuple(0.4 + 0.1 * m for _ in thresholds),))
              for dataset in datasets for m in range(models) for method in suffix]
    figure = curves_figure(curves)
    write_png(figure, tmp_path / "curves.png")  # as save() renders it
    width, height = figure.canvas.get_width_height()
    box = figure.legends[0].get_window_extent()
    assert 0 <= box.x0 and box.x1 <= width and 0 <= box.y0 and box.y1 <= height, (box, width, height)
    for ax in figure.axes:  # and below the panels, not over them
        assert box.y1 <= ax.get_window_extent().y0


def test_an_untimed_run_s_runtime_is_said_to_be_unmeasured(fixture_run, tmp_path):
    # results/ is written with run --no-timings: its runtime is n/a, and the table says why.
    from conftest import REPO

    _, timed = fixture_run
    result = CliRunner().invoke(main, ["compare", str(REPO / "results"), str(timed), "--label",
                                       f"{REPO / 'results'}=Untimed", "--out", str(tmp_path / "c"), "--quiet"])
    assert result.exit_code == 0, result.output
    text = (tmp_path / "c" / "table_runtime.md").read_text()
    assert "n/a for Untimed: written with `run --no-timings`" in text
    assert "| CULane | Untimed | n/a |" in text and "| CULane | SCNN | n/a |" not in text


def test_a_score_folder_that_is_no_sweep_says_what_compare_takes_of_score(tmp_path):
    # It said only "not a folder written by `roneld-eval run` (`roneld-eval score culane` wrote it)",
    # though compare takes score's folders as sweeps.
    from roneld_eval.benchmarks.culane.synth import synth_culane

    made = synth_culane(tmp_path / "set", clips=1, frames=2, seed=1, maps_format="lanes")
    scored = CliRunner().invoke(main, ["score", "culane", "--data-root", str(made.data_root), "--pred-root",
                                       str(made.maps_root), "--quiet", "--out", str(tmp_path / "one")])
    assert scored.exit_code == 0, scored.output
    result = CliRunner().invoke(main, ["compare", str(tmp_path / "one"), "--out", str(tmp_path / "c")])
    assert result.exit_code == 2 and result.output.count("\n") == 1, result.output
    assert ("(`roneld-eval score culane` wrote it); compare takes a folder of `score` only as a checkpoint sweep, "
            "which it writes (sweep.csv) when given several checkpoints (a glob, --pred-roots-from)") in result.output


def _coloured_runs(row) -> int:
    """How many separate runs of non-white pixels a row of an RGB or RGBA image holds."""
    inked = (row[:, :3] < 0.85).any(axis=1)
    return int(inked[0]) + int((inked[1:] & ~inked[:-1]).sum())


def test_a_dashed_curves_legend_sample_shows_its_gap(tmp_path):
    # The first model draws the widest line, and its dashes were long enough that the one gap
    # of the legend sample lay under the marker: its baseline read as solid, like "+ RONELD".
    import matplotlib.image

    from roneld_eval.comparison.figure import Curve, curves_figure
    from roneld_eval.report.figure_files import write_png

    thresholds = tuple(k / 100 for k in range(30, 51))
    curves = [Curve("CULane", model, method, model + ("" if method == "baseline" else " + RONELD"), thresholds,
                    ((0.6 if method == "baseline" else 0.8,) * len(thresholds),))
              for model in ("Model-1", "Model-2") for method in ("baseline", "roneld")]
    figure = curves_figure(curves)
    write_png(figure, tmp_path / "curves.png")  # as save() writes it
    pixels = matplotlib.image.imread(tmp_path / "curves.png")
    height = pixels.shape[0]
    legend = figure.legends[0]
    renderer = figure.canvas.get_renderer()
    for handle, text in zip(legend.legend_handles, legend.get_texts()):
        box = handle.get_window_extent(renderer)
        row = pixels[height - 1 - round((box.y0 + box.y1) / 2), int(box.x0):int(box.x1) + 1]
        runs = _coloured_runs(row)
        if text.get_text().endswith("RONELD"):
            assert runs == 1, (text.get_text(), runs)  # solid
        else:
            assert runs >= 2, (text.get_text(), runs)  # a gap between dashes shows
