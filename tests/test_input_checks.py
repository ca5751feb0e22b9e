"""Every bad input is one line naming the file (or setting) and the problem, exit status 2.

Configuration values (TOML and --set alike), the one PFT switch, dataset inputs (wrong roots,
TuSimple rows and frame numbers, image names, BOMs, FIFOs, unreadable folders, other
locales), corrupt PNGs and maps stored in another format. Cases run the CLI as a user types
it where that is possible, and the library where it is clearer.
"""

from __future__ import annotations

import errno
import json
import os
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st

from roneld_eval import api
from roneld_eval.cli import main
from roneld_eval.config import (
    RANGES,
    DatasetConfig,
    EvalConfig,
    MapsConfig,
    RoneldParams,
    parse_setting,
)
from roneld_eval.presets import preset_names
from roneld_eval.thresholds import parse_thresholds
from roneld_eval.api import read_dataset
from roneld_eval.benchmarks.culane.reader import read_culane
from roneld_eval.benchmarks.tusimple.reader import read_tusimple
from roneld_eval.errors import ConfigError, InputError
from roneld_eval.extract.roneld import RoneldTracker
from roneld_eval.lanes_io import read_lines_txt, read_text
from roneld_eval.maps import load_maps, required_paths
from roneld_eval.model import Frame, image_stem
from roneld_eval.benchmarks.culane.synth import synth_culane
from roneld_eval.benchmarks.tusimple.synth import synth_tusimple

ROWS = list(range(160, 720, 10))


# ---- helpers -------------------------------------------------------------------------------


def one_line(result, *expected: str) -> str:
    """The CLI failed with exit 2 and exactly one line 'error: ...' holding every expected text."""
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output, result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), result.output
    for text in expected:
        assert text in lines[0], lines[0]
    return lines[0]


def run_cli(*args: str):
    return CliRunner().invoke(main, list(args))


def built_config(monkeypatch, tmp_path, *args: str) -> EvalConfig:
    """The configuration `roneld-eval run ARGS` builds (the run itself is not started)."""
    seen = []

    def captured(config, out, **kwargs):
        seen.append(config)
        raise ConfigError("captured")

    monkeypatch.setattr(api, "run", captured)
    result = run_cli("run", "--quiet", "--out", str(tmp_path / "out"), *args)
    assert seen, result.output
    return seen[0]


@pytest.fixture
def no_hang():
    """Fail (instead of hanging) when a check under test blocks, e.g. on opening a FIFO."""
    def timeout(signum, frame):
        raise TimeoutError("the command blocked")

    previous = signal.signal(signal.SIGALRM, timeout)
    signal.alarm(20)
    yield
    signal.alarm(0)
    signal.signal(signal.SIGALRM, previous)


@pytest.fixture(scope="session")
def base_sets(tmp_path_factory):
    root = tmp_path_factory.mktemp("checks")
    synth_culane(root / "culane", clips=2, frames=2, seed=5)
    synth_culane(root / "culane-png", clips=1, frames=2, seed=5, maps_format="scnn-png")
    synth_tusimple(root / "tusimple", clips=1, frames=20, seed=5)
    return root


@pytest.fixture
def sets(base_sets, tmp_path):
    shutil.copytree(base_sets, tmp_path / "sets")
    return tmp_path / "sets"


def run_args(root: Path, out: Path, *extra: str, dataset: str = "culane") -> list[str]:
    return ["run", "--dataset", dataset, "--data-root", str(root / "data"), "--maps-root", str(root / "maps"),
            "--workers", "1", "--quiet", "--out", str(out), *extra]


def write_labels(path: Path, records: list[dict]) -> Path:
    path.write_text("".join(json.dumps(record) + "\n" for record in records), encoding="utf-8")
    return path


def tusimple_record(raw_file="clips/0530/a/20.jpg", h_samples=None, lanes=None) -> dict:
    rows = ROWS if h_samples is None else h_samples
    return {"lanes": [[600] * len(rows)] if lanes is None else lanes, "h_samples": rows, "raw_file": raw_file}


# ---- 1. configuration values ---------------------------------------------------------------


@pytest.mark.parametrize("value, expected", [
    ("0.3:0.5", "must be START:STOP:STEP"),
    ("0.3:0.5:0.1:1", "must be START:STOP:STEP"),
    ("nan", "'nan' is not a finite number"),
    ("inf", "is not a finite number"),
    ("0:0.99:1e-7", "at most 1,000"),
    ("0.3:0.5:0", "positive step"),
    ("0.5:0.3:0.1", "start <= stop"),
    ("0.3:1.5:0.1", "[0, 1)"),
    ("abc", "'abc' is not a number"),
    ("0.3:0.5:1e-13", "more than 12 decimals"),
    (",", "no thresholds given"),
])
def test_bad_thresholds_are_one_line(tmp_path, value, expected):
    one_line(run_cli("run", "--thresholds", value, "--out", str(tmp_path)), expected)


def test_score_iou_is_parsed_the_same_way(tmp_path):
    result = run_cli("score", "culane", "--data-root", str(tmp_path), "--pred-root", str(tmp_path),
                     "--iou", "0.3:0.5:0.1:1")
    one_line(result, "thresholds '0.3:0.5:0.1:1' must be START:STOP:STEP")


def test_a_sweep_of_a_thousand_thresholds_is_the_limit():
    assert len(parse_thresholds("0:0.999:0.001")) == 1000
    with pytest.raises(ConfigError, match="1,001 values"):
        parse_thresholds("0:0.5:0.0005")  # refused before any list is built


# (setting, --set value, the same value in TOML, expected text)
RANGE_CASES = [
    ("paper.gt_thickness_px", "0", "0", "paper.gt_thickness_px must be in [2, 1000], got 0"),
    ("paper.pred_thickness_px", "-3", "-3", "paper.pred_thickness_px must be in [2, 1000], got -3"),
    ("paper.thresholds", "0.3:0.5:-0.1", '"0.3:0.5:-0.1"', "positive step"),
    ("official.iou_threshold", "1", "1", "official.iou_threshold must be in [0, 1), got 1"),
    ("official.iou_threshold", "nan", "nan", "official.iou_threshold must be a finite number, got nan"),
    ("official.lane_width_px", "1", "1", "official.lane_width_px must be in [2, 1000], got 1"),
    ("maps.width", "0", "0", "maps.width must be in [1, 10000], got 0"),
    ("maps.height", "-1", "-1", "maps.height must be in [1, 10000], got -1"),
    ("maps.lane_channels", "1000000000", "1000000000", "maps.lane_channels must be in [1, 32]"),
    ("baseline.threshold", "1.5", "1.5", "baseline.threshold must be in [0, 1), got 1.5"),
    ("baseline.existence_threshold", "-0.5", "-0.5", "baseline.existence_threshold must be in [0, 1]"),
    ("baseline.min_points", "0", "0", "baseline.min_points must be in [2, 10000], got 0"),
    ("baseline.rows", "0:100000:1", '"0:100000:1"', "must lie inside the 590-row image"),
    ("roneld.center_ratio", "1", "1", "roneld.center_ratio must be in (0, 1), got 1"),
    ("roneld.lane_ratio", "-0.1", "-0.1", "roneld.lane_ratio must be in [0, 1), got -0.1"),
    ("dataset.limit", "0", "0", "dataset.limit must be >= 1, got 0"),
    ("dataset.limit", '"2"', '"2"', "dataset.limit must be an integer, got the text '2'"),
    ("workers", "0", "0", "workers must be in [1, 1024], got 0"),
    ("workers", "2.5", "2.5", "workers must be an integer, got 2.5"),
    ("save_lanes", "0", "0", "save_lanes must be true or false, got 0"),
    ("pft_ablation", "yes", '"yes"', "pft_ablation must be true or false"),
    ("methods", "baseline,magic", '["baseline", "magic"]', "unknown method 'magic'"),
]


@pytest.mark.parametrize("setting, value, toml_value, expected", RANGE_CASES,
                         ids=[f"{c[0]}={c[1]}" for c in RANGE_CASES])
def test_values_are_checked_the_same_in_toml_and_set(tmp_path, setting, value, toml_value, expected):
    by_set = one_line(run_cli("run", "--set", f"{setting}={value}", "--out", str(tmp_path / "o")), expected)
    section, _, key = setting.rpartition(".")
    path = tmp_path / "c.toml"
    path.write_text(f"[{section}]\n{key} = {toml_value}\n" if section else f"{key} = {toml_value}\n")
    by_file = one_line(run_cli("run", "--config", str(path), "--out", str(tmp_path / "o")), str(path), expected)
    assert by_file.endswith(by_set[len("error: "):])  # the same message, the file named before it


def test_every_numeric_setting_has_a_documented_range():
    numeric = []
    sections = ("dataset", "maps", "baseline", "roneld", "paper", "official")
    for section, owner in [("", EvalConfig), *((name, type(getattr(EvalConfig(), name))) for name in sections)]:
        for item in owner.__dataclass_fields__.values():
            if str(item.type).split("|")[0].strip() in ("int", "float"):
                numeric.append(f"{section}.{item.name}" if section else item.name)
    assert len(numeric) == 18 and sorted(set(numeric) - set(RANGES)) == []


def test_set_values_take_the_field_types(monkeypatch, tmp_path):
    config = built_config(monkeypatch, tmp_path, "--set", "methods=baseline", "--set", "paper.thresholds=0.5",
                          "--set", "workers=2", "--set", "model=My model", "--set", 'maps.npz_key="a=b"')
    assert config.methods == ("baseline",)  # not split into letters
    assert config.paper.thresholds == "0.5" and config.workers == 2 and config.model == "My model"
    assert config.maps.npz_key == "a=b"
    config = built_config(monkeypatch, tmp_path, "--set", "methods=baseline, roneld", "--set", "dataset.limit=2")
    assert config.methods == ("baseline", "roneld") and config.dataset.limit == 2
    config = built_config(monkeypatch, tmp_path, "--set", 'methods=["roneld"]', "--set", "roneld.lane_ratio=0")
    assert config.methods == ("roneld",) and config.roneld.lane_ratio == 0.0
    assert parse_setting("paper.thresholds=0.30:0.50:0.05") == ("paper.thresholds", "0.30:0.50:0.05")
    assert parse_setting(" workers = 3 ") == ("workers", 3)


@pytest.mark.parametrize("setting, expected", [
    ("paper.thicknes_rule=height", "unknown setting 'paper.thicknes_rule' (did you mean paper.thickness_rule?)"),
    ("dataset=x", "unknown setting 'dataset'"),
    ("novalue", "--set needs SECTION.KEY=VALUE"),
])
def test_bad_set_keys(tmp_path, setting, expected):
    one_line(run_cli("run", "--set", setting, "--out", str(tmp_path)), expected)


def test_a_latin1_config_file_is_one_line(tmp_path):
    path = tmp_path / "latin1.toml"
    path.write_bytes('model = "Modèle"\n'.encode("latin-1"))
    one_line(run_cli("run", "--config", str(path), "--out", str(tmp_path / "o")), str(path), "not UTF-8 text",
             "0xe8")


def test_a_config_file_with_a_bom_reads(tmp_path):
    path = tmp_path / "bom.toml"
    path.write_bytes(b"\xef\xbb\xbfmodel = \"X\"\n")
    assert EvalConfig.from_toml(path).model == "X"


def test_a_config_path_that_is_a_fifo_or_a_folder(tmp_path, no_hang):
    fifo = tmp_path / "fifo.toml"
    os.mkfifo(fifo)
    one_line(run_cli("run", "--config", str(fifo), "--out", str(tmp_path / "o")), str(fifo), "not a regular file")
    one_line(run_cli("run", "--config", str(tmp_path), "--out", str(tmp_path / "o")), "not a regular file")


def test_text_that_config_toml_cannot_hold_is_refused():
    with pytest.raises(ConfigError, match=r"dataset.data_root is not valid Unicode text .*\\udcff"):
        EvalConfig().with_overrides(**{"dataset.data_root": "/data/\udcff"})
    with pytest.raises(ConfigError, match="maps.root holds a NUL character"):
        EvalConfig().with_overrides(**{"maps.root": "/maps\0x"})


def test_names_that_are_not_utf8_are_refused_by_score_compare_and_show_before_any_work(tmp_path):
    # They failed with UnicodeEncodeError when the path was recorded, after all the work.
    odd = os.fsdecode(b"s\xff")
    synth_culane(tmp_path / odd, clips=1, frames=2, seed=1)
    data = tmp_path / odd / "data"
    one_line(run_cli("score", "culane", "--data-root", str(data), "--pred-root", str(data),
                     "--out", str(tmp_path / "o")), "\\udcff/data' is not valid Unicode text")
    assert not (tmp_path / "o").exists()
    one_line(run_cli("compare", str(tmp_path / odd), "--out", str(tmp_path / "c")), "is not valid Unicode text")
    one_line(run_cli("show", "--run", str(tmp_path / odd), "--worst", "1"), "is not valid Unicode text")
    methods = tmp_path / "methods"
    shutil.copytree(data, methods / os.fsdecode(b"m\xff"))
    shutil.copytree(data, methods / "fine")
    one_line(run_cli("score", "culane", "--data-root", str(methods / "fine"), "--pred-root", str(methods),
                     "--out", str(tmp_path / "o")), "folder's name is not valid Unicode text")
    assert not (tmp_path / "o").exists()


AWKWARD = st.text(st.characters(blacklist_categories=("Cs",), blacklist_characters="\0"), max_size=24)


@settings(max_examples=150, deadline=None, derandomize=True)
@given(AWKWARD, AWKWARD, AWKWARD)
def test_config_toml_round_trips_awkward_text(model, root, key):
    config = EvalConfig(
        model="m" + model,  # a blank model is refused (it labels every table); the awkward text still follows
        dataset=DatasetConfig(data_root=root, list_file=root + '"\\\n\t\x7f'),
        maps=MapsConfig(root="\\" + root, npz_key=key),
    )
    assert EvalConfig.from_toml_text(config.to_toml()) == config


@pytest.mark.parametrize("text", ['a"b', "a\\b", "C:\\data\\new", "line\nbreak\r\n", "\x01\x1f\x7f\x08\x0c",
                                  "tab\there", "\u2028\u2029", "é 😀", "'''", '"""', "\\u0041", "#[x] = 1"])
def test_config_toml_round_trips_named_cases(tmp_path, text):
    config = EvalConfig.preset("enet-sad-culane").with_overrides(**{
        "model": "m" + text, "dataset.data_root": text, "maps.root": text, "maps.npz_key": text, "dataset.limit": 3,
        "pft_ablation": True})
    path = tmp_path / "config.toml"
    path.write_text(config.to_toml(), encoding="utf-8")
    assert EvalConfig.from_toml(path) == config


def test_every_preset_and_summary_dict_round_trip():
    for name in preset_names():
        config = EvalConfig.preset(name)
        assert EvalConfig.from_toml_text(config.to_toml()) == config
        assert EvalConfig.from_dict(config.to_dict()) == config  # None values as summary.json keeps them


# ---- 2. one PFT switch -----------------------------------------------------------------------


def test_roneld_pft_setting_is_gone(tmp_path):
    one_line(run_cli("run", "--set", "roneld.pft=0", "--out", str(tmp_path)),
             "roneld.pft was removed", '"roneld-nopft"')
    path = tmp_path / "old.toml"
    path.write_text("[roneld]\ncenter_ratio = 0.5\npft = false\n")
    one_line(run_cli("run", "--config", str(path), "--out", str(tmp_path / "o")), str(path),
             "roneld.pft was removed", 'methods = ["baseline", "roneld-nopft"]')
    assert "pft" not in RoneldParams.__dataclass_fields__


def test_no_pft_and_the_ablation_are_methods(monkeypatch, tmp_path):
    assert built_config(monkeypatch, tmp_path, "--no-pft").methods == ("baseline", "roneld-nopft")
    assert built_config(monkeypatch, tmp_path, "--pft-ablation").methods == ("baseline", "roneld", "roneld-nopft")
    assert built_config(monkeypatch, tmp_path, "--no-pft", "--methods", "roneld").methods == ("roneld-nopft",)
    config = built_config(monkeypatch, tmp_path, "--no-pft")
    assert EvalConfig.from_toml_text(config.to_toml()) == config
    assert "pft =" not in config.to_toml().replace("pft_ablation =", "")


@pytest.mark.parametrize("args, expected", [
    (["--no-pft", "--pft-ablation"], "--no-pft and --pft-ablation contradict each other"),
    (["--no-pft", "--set", "pft_ablation=true"], "--no-pft: cannot turn PFT off"),
    (["--no-pft", "--methods", "baseline,roneld,roneld-nopft"], "--no-pft: cannot turn PFT off"),
    (["--no-pft", "--methods", "baseline"], "RONELD is not among the methods (baseline)"),
])
def test_contradictory_pft_options(tmp_path, args, expected):
    one_line(run_cli("run", *args, "--out", str(tmp_path)), expected)


def test_the_tracker_takes_pft_from_the_method():
    maps = np.zeros((4, 40, 60), np.uint8)
    maps[1, 5:, 20] = 200
    maps[2, 5:, 40] = 200
    gone = maps.copy()
    gone[1] = 0
    with_pft, without = RoneldTracker(RoneldParams(), pft=True), RoneldTracker(RoneldParams(), pft=False)
    for _ in range(4):
        with_pft(maps), without(maps)
    assert with_pft(gone).left is not None and without(gone).left is None


# ---- 3a. a wrong CULane root -----------------------------------------------------------------


def test_a_culane_root_without_any_labels_is_refused(sets, tmp_path):
    root = sets / "culane"
    wrong = tmp_path / "wrong"
    (wrong / "list").mkdir(parents=True)
    shutil.copy(root / "data" / "list" / "test.txt", wrong / "list" / "test.txt")
    result = run_cli("run", "--data-root", str(wrong), "--maps-root", str(root / "maps"), "--out", str(tmp_path / "o"))
    first = wrong / "driver_100_30frame" / "05181432_0203.MP4" / "00000.lines.txt"
    one_line(result, f"error: {wrong}: no listed frame has its ground truth here", f"first missing: {first}")


def test_the_root_check_stops_at_the_first_label(sets, monkeypatch):
    stats = []
    original = os.stat
    monkeypatch.setattr(os, "stat", lambda path, *a, **k: stats.append(str(path)) or original(path, *a, **k))
    read_dataset("culane", sets / "culane" / "data", labels=False)
    assert sum(path.endswith(".lines.txt") for path in stats) == 1


# ---- 3b. TuSimple h_samples, 3c. frame numbers ----------------------------------------------------


@pytest.mark.parametrize("record, expected", [
    (tusimple_record(h_samples=[], lanes=[[]]), "h_samples is empty"),
    (tusimple_record(h_samples=[160, 1e9]), "h_samples row 1e+09 lies outside the 720-row image"),
    (tusimple_record(h_samples=[-10, 170]), "h_samples row -10 lies outside"),
    (tusimple_record(h_samples=[160, 160]), "h_samples lists row 160 twice"),
    (tusimple_record(raw_file="clips/x/3000000.jpg"), "frame number 3000000"),
])
def test_bad_tusimple_labels_are_one_line(tmp_path, record, expected, no_hang):
    data = tmp_path / "data"
    data.mkdir()
    (tmp_path / "maps").mkdir()
    write_labels(data / "test_label.json", [tusimple_record(raw_file="clips/0530/ok/20.jpg"), record])
    result = run_cli(*run_args(tmp_path, tmp_path / "o", dataset="tusimple"))
    one_line(result, "test_label.json:2:", expected)


def test_score_tusimple_checks_h_samples_too(tmp_path):
    labels = write_labels(tmp_path / "labels.json", [tusimple_record(h_samples=[], lanes=[])])
    pred = write_labels(tmp_path / "pred.json", [{"raw_file": "clips/0530/a/20.jpg", "lanes": []}])
    one_line(run_cli("score", "tusimple", "--labels", str(labels), "--pred", str(pred)),
             "labels.json:1:", "h_samples is empty")


def test_tusimple_frames_follow_the_labelled_name(tmp_path):
    write_labels(tmp_path / "test_label.json", [tusimple_record(raw_file="clips/a/5"),
                                                 tusimple_record(raw_file="clips/b/3.png")])
    clips = read_tusimple(tmp_path).clips
    assert [f.relpath for f in clips[0].frames] == ["clips/a/1", "clips/a/2", "clips/a/3", "clips/a/4", "clips/a/5"]
    assert [f.relpath for f in clips[1].frames] == ["clips/b/1.png", "clips/b/2.png", "clips/b/3.png"]


# ---- 3d. image names without (or with another) extension ------------------------------------------


def test_image_stem_cuts_at_the_file_names_last_dot():
    assert image_stem("driver_x/05.MP4/00000.jpg") == "driver_x/05.MP4/00000"
    assert image_stem("driver_x/05.MP4/00000") == "driver_x/05.MP4/00000"
    assert image_stem("driver_x/05.MP4/00000.png") == "driver_x/05.MP4/00000"
    assert image_stem("clips/a.b/.hidden") == "clips/a.b/.hidden"
    assert Frame("driver_x/05.MP4/00000").stem == "driver_x/05.MP4/00000"


def test_entries_without_an_extension_find_their_files(sets, tmp_path):
    root = sets / "culane"
    listing = root / "data" / "list" / "test.txt"
    relpaths = [line.strip().lstrip("/") for line in listing.read_text().splitlines()]
    listing.write_text("".join(f"/{r[:-4]}\n" for r in relpaths))  # /driver_x/05.MP4/00000
    dataset = read_culane(root / "data")
    frame = dataset.clips[0].frames[0]
    assert frame.relpath.endswith(".MP4/00000") and len(frame.lanes) > 0  # its .lines.txt was read
    assert required_paths(root / "maps", frame.relpath, MapsConfig())[0].name == "00000.npy"
    assert load_maps(root / "maps", frame.relpath, MapsConfig()).probabilities.shape == (4, 288, 800)
    next(root.joinpath("maps").rglob("00030.npy")).unlink()
    result = run_cli(*run_args(root, tmp_path / "o"))
    one_line(result, "maps missing for 1 frame", "05181432_0203.MP4/00030.npy")


def test_entries_with_another_extension_give_the_same_numbers(sets, tmp_path):
    root = sets / "culane"
    assert run_cli(*run_args(root, tmp_path / "jpg")).exit_code == 0
    listing = root / "data" / "list" / "test.txt"
    listing.write_text(listing.read_text().replace(".jpg", ".png"))
    assert run_cli(*run_args(root, tmp_path / "png")).exit_code == 0
    assert (tmp_path / "png" / "accuracy.csv").read_bytes() == (tmp_path / "jpg" / "accuracy.csv").read_bytes()


def test_category_lists_match_a_test_list_without_extensions(sets, tmp_path):
    # Category rows were empty, silently, when the test list and the category lists differed
    # only in the images' extension.
    root = sets / "culane"
    listing = root / "data" / "list" / "test.txt"
    relpaths = [line.strip().lstrip("/") for line in listing.read_text().splitlines()]
    split = root / "data" / "list" / "test_split"
    for old in split.iterdir():
        old.unlink()
    (split / "test0_normal.txt").write_text("".join(f"{r}\n" for r in relpaths[:4]))
    assert run_cli(*run_args(root, tmp_path / "jpg")).exit_code == 0
    listing.write_text("".join(f"/{r[:-4]}\n" for r in relpaths))
    assert run_cli(*run_args(root, tmp_path / "bare")).exit_code == 0
    assert (tmp_path / "bare" / "categories.csv").read_bytes() == (tmp_path / "jpg" / "categories.csv").read_bytes()
    normal = [line for line in (tmp_path / "bare" / "categories.csv").read_text().splitlines()
              if line.startswith("normal,")]
    assert normal and all(int(line.split(",")[3]) > 0 for line in normal)
    (split / "test1_other.txt").write_text("nowhere/00000.jpg\n")
    one_line(run_cli(*run_args(root, tmp_path / "o")), "test1_other.txt: none of its 1 frames is in the test list")
    (split / "test1_other.txt").rename(split / "test1_x")
    one_line(run_cli(*run_args(root, tmp_path / "o")), "test1_x: a category list must end in .txt")
    (split / "test1_x").rename(split / "test1_night and rain.txt")  # was left out of every table, silently
    one_line(run_cli(*run_args(root, tmp_path / "o")), "test1_night and rain.txt: a category list is named "
                                                       "test<number>_<name>.txt with letters, digits and _ only")


# ---- 3e. byte-order marks --------------------------------------------------------------------------


BOM = b"\xef\xbb\xbf"


def test_boms_are_dropped_in_every_text_input(sets, tmp_path):
    data = sets / "culane" / "data"
    listing = data / "list" / "test.txt"
    listing.write_bytes(BOM + listing.read_bytes())
    split = data / "list" / "test_split"
    for category in split.glob("*.txt"):
        category.write_bytes(BOM + category.read_bytes())
    labels = sorted(data.rglob("*.lines.txt"))[0]
    labels.write_bytes(BOM + labels.read_bytes())
    dataset = read_culane(data)
    assert dataset.n_frames == 4 and dataset.clips[0].frames[0].relpath.startswith("driver_100")
    members = set().union(*dataset.categories.values())
    assert members == {f.relpath for c in dataset.clips for f in c.frames}  # no first frame lost
    assert len(dataset.clips[0].frames[0].lanes) == len(read_lines_txt(labels))
    assert not read_text(labels).startswith("\ufeff")

    exist = sorted((sets / "culane-png" / "maps").rglob("*.exist.txt"))[0]
    exist.write_bytes(BOM + exist.read_bytes())
    frame = str(exist.relative_to(sets / "culane-png" / "maps")).replace(".exist.txt", ".jpg")
    assert load_maps(sets / "culane-png" / "maps", frame, MapsConfig(format="scnn-png")).existence is not None

    label_file = sets / "tusimple" / "data" / "test_label.json"
    label_file.write_bytes(BOM + label_file.read_bytes())
    assert len(read_tusimple(sets / "tusimple" / "data").clips) == 1


# ---- 3f. one frame under two names ------------------------------------------------------------------


def test_a_frame_listed_under_two_extensions(sets, tmp_path):
    root = sets / "culane"
    listing = root / "data" / "list" / "test.txt"
    first = listing.read_text().splitlines()[0]
    listing.write_text(listing.read_text() + first.replace(".jpg", ".png") + "\n")
    one_line(run_cli(*run_args(root, tmp_path / "o")), "test.txt:5:", "00000.png is listed twice (first on line 1 as ")


def test_a_tusimple_frame_labelled_under_two_extensions(tmp_path):
    write_labels(tmp_path / "test_label.json", [tusimple_record(), tusimple_record(raw_file="clips/0530/a/20.png")])
    with pytest.raises(InputError, match=r"test_label.json:2: clips/0530/a/20.png is labelled twice"):
        read_tusimple(tmp_path)


# ---- 3g. only regular files are read ------------------------------------------------------------------


def _fifo_in_place_of(path: Path) -> Path:
    path.unlink()
    os.mkfifo(path)
    return path


@pytest.mark.parametrize("folder, target, extra, expected", [
    ("culane", lambda r: sorted((r / "data").rglob("*.lines.txt"))[0], [], "is a FIFO (named pipe)"),
    ("culane", lambda r: r / "data" / "list" / "test.txt", [], "is a FIFO (named pipe)"),
    ("culane", lambda r: sorted((r / "maps").rglob("*.npy"))[0], [], "is a FIFO (named pipe)"),
    ("culane-png", lambda r: sorted((r / "maps").rglob("*_1_avg.png"))[0], ["--maps-format", "scnn-png"],
     "is a FIFO (named pipe)"),
    ("culane-png", lambda r: sorted((r / "maps").rglob("*.exist.txt"))[0], ["--maps-format", "scnn-png"],
     "is a FIFO (named pipe)"),
])
def test_a_fifo_is_one_line_never_a_hang(sets, tmp_path, no_hang, folder, target, extra, expected):
    root = sets / folder
    fifo = _fifo_in_place_of(target(root))
    one_line(run_cli(*run_args(root, tmp_path / "o", *extra)), str(fifo), expected)


def test_a_fifo_as_npz_maps_or_label_file(tmp_path, no_hang):
    os.mkfifo(tmp_path / "00000.npz")
    with pytest.raises(InputError, match=r"00000.npz: is a FIFO \(named pipe\), not a regular file"):
        load_maps(tmp_path, "00000.jpg", MapsConfig(format="npz"))
    os.mkfifo(tmp_path / "test_label.json")
    with pytest.raises(InputError, match=r"test_label.json: is a FIFO"):
        read_tusimple(tmp_path)


def test_a_device_given_as_the_list_file(sets, tmp_path, no_hang):
    root = sets / "culane"
    one_line(run_cli(*run_args(root, tmp_path / "o", "--list", "/dev/zero")), "/dev/zero", "is a device")


def test_a_folder_given_as_a_map_file(sets, tmp_path):
    root = sets / "culane"
    target = sorted((root / "maps").rglob("*.npy"))[0]
    target.unlink()
    target.mkdir()
    one_line(run_cli(*run_args(root, tmp_path / "o")), str(target), "is a folder, not a file")


# ---- 3h. every OSError is an InputError naming the file ---------------------------------------------


def _deny(monkeypatch, folder: Path) -> None:
    """Simulate a folder without permission (tests may run as root, which chmod cannot stop)."""
    folder = str(folder)

    def guarded(function):
        def call(path, *args, **kwargs):
            text = os.fsdecode(path) if isinstance(path, (str, bytes, os.PathLike)) else ""
            if text.startswith(folder + os.sep):
                raise PermissionError(errno.EACCES, os.strerror(errno.EACCES), text)
            return function(path, *args, **kwargs)
        return call

    monkeypatch.setattr(os, "stat", guarded(os.stat))
    monkeypatch.setattr(os, "open", guarded(os.open))


@pytest.mark.parametrize("side", ["data", "maps"])
def test_an_unreadable_clip_folder_is_skipped_with_skip(sets, tmp_path, monkeypatch, side):
    root = sets / "culane"
    folder = root / side / "driver_101_30frame"
    _deny(monkeypatch, folder)
    failed = run_cli(*run_args(root, tmp_path / "fail"))
    one_line(failed, str(folder), "Permission denied")
    result = run_cli(*run_args(root, tmp_path / "o", "--on-error", "skip"))
    assert result.exit_code == 0, result.output
    summary = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert summary["counts"]["frames"] == 2 and summary["skipped"]
    assert all(str(folder) in line for line in summary["skipped"])


@pytest.mark.skipif(not hasattr(os, "geteuid") or os.geteuid() == 0, reason="root reads any folder")
def test_a_real_unreadable_clip_folder(sets, tmp_path):
    root = sets / "culane"
    folder = root / "data" / "driver_101_30frame"
    folder.chmod(0)
    try:
        result = run_cli(*run_args(root, tmp_path / "o", "--on-error", "skip"))
    finally:
        folder.chmod(0o755)
    assert result.exit_code == 0 and "Permission denied" in result.output


def test_a_label_file_that_is_not_utf8_is_skippable(sets, tmp_path):
    root = sets / "culane"
    labels = sorted((root / "data").rglob("*.lines.txt"))[1]
    labels.write_bytes(b"1 590 2 580 \xe9\n")
    one_line(run_cli(*run_args(root, tmp_path / "o")), str(labels), "not a UTF-8 text file (byte 0xe9 at offset 12)")


def test_a_tusimple_name_that_is_not_unicode(tmp_path):
    data = tmp_path / "data"
    data.mkdir()
    (tmp_path / "maps").mkdir()
    (data / "test_label.json").write_text(
        json.dumps(tusimple_record()) + "\n" + json.dumps(tusimple_record()).replace("0530/a", "0530/\\udcff") + "\n")
    one_line(run_cli(*run_args(tmp_path, tmp_path / "o", dataset="tusimple")),
             "test_label.json:2:", "is not valid Unicode text")


def test_non_ascii_names_under_a_non_utf8_locale(tmp_path):
    video = "driver_é/05181432_0203.MP4"
    data, maps = tmp_path / "data", tmp_path / "maps"
    (data / video).mkdir(parents=True)
    (maps / video).mkdir(parents=True)
    (data / "list").mkdir()
    (data / "list" / "test.txt").write_text(f"/{video}/00000.jpg\n", encoding="utf-8")
    (data / video / "00000.lines.txt").write_text("800 589 810 400\n", encoding="utf-8")
    np.save(maps / video / "00000.npy", np.zeros((4, 288, 800), np.uint8))
    script = (
        "import sys; from roneld_eval.api import read_dataset; from roneld_eval.datasets import load_labels\n"
        "from roneld_eval.maps import load_maps; from roneld_eval.config import MapsConfig\n"
        "from roneld_eval.resolve import benchmark_named\n"
        "b = benchmark_named('culane'); d = read_dataset(b, sys.argv[1], labels=False)\n"
        "clip = load_labels(b, d, d.clips[0])\n"
        "m = load_maps(sys.argv[2], clip.frames[0].relpath, MapsConfig())\n"
        "print(sys.getfilesystemencoding(), len(clip.frames[0].lanes), m.probabilities.shape)\n"
    )
    env = dict(os.environ, LC_ALL="C", LANG="C", PYTHONCOERCECLOCALE="0", PYTHONUTF8="0")
    done = subprocess.run([sys.executable, "-c", script, str(data), str(maps)], env=env, capture_output=True,
                          text=True, encoding="utf-8", errors="replace", timeout=60)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["ascii", "1", "(4,", "288,", "800)"]


# ---- 3i. corrupt PNGs: our line only ----------------------------------------------------------------


@pytest.mark.parametrize("corrupt, expected", [
    (lambda data: data[: len(data) // 2], "truncated PNG"),
    (lambda data: data[:100] + bytes([data[100] ^ 0xFF]) + data[101:], "fails its CRC check"),
    (lambda data: b"hello", "not a PNG file"),
])
def test_a_corrupt_png_prints_only_our_line(sets, tmp_path, capfd, corrupt, expected):
    root = sets / "culane-png"
    png = sorted((root / "maps").rglob("*_2_avg.png"))[0]
    png.write_bytes(corrupt(png.read_bytes()))
    result = run_cli(*run_args(root, tmp_path / "o", "--maps-format", "scnn-png"))
    one_line(result, str(png), expected)
    assert "libpng" not in capfd.readouterr().err


# ---- 4. presets and maps in another format --------------------------------------------------------


def test_maps_found_in_another_format_are_named(sets, tmp_path):
    result = run_cli(*run_args(sets / "culane-png", tmp_path / "o"))  # the presets' npy
    one_line(result, "maps missing for 2 frames of 1 clip:",
             "00000.npy (found 00000_1_avg.png: use --maps-format scnn-png)")
    result = run_cli(*run_args(sets / "culane", tmp_path / "o", "--maps-format", "npz"))
    one_line(result, "00000.npz (found 00000.npy: use --maps-format npy)")
    shutil.rmtree(sets / "culane" / "maps" / "driver_100_30frame")
    result = run_cli(*run_args(sets / "culane", tmp_path / "o"))
    line = one_line(result, "maps missing for 2 frames of 1 clip:")
    assert "(found" not in line


def test_preset_comments_agree_with_their_format():
    from roneld_eval.presets import preset_path

    for name in preset_names():
        text = preset_path(name).read_text(encoding="utf-8")
        config = EvalConfig.preset(name)
        maps_section = text.split("\n[maps]\n")[1].split("\n[baseline]\n")[0]
        if name == "lanes-vil100":  # no model's maps are public for VIL-100: a detector's lane files
            assert config.maps.format == "lanes" and "--maps-format lanes" in text.split("\n[maps]\n")[0]
        elif name == "segmentation-llamas":  # LLAMAS's own segmentation format
            head = text.split("\n[maps]\n")[0]
            assert config.maps.format == "llamas-png" and '"llamas-png"' in head and "--maps-format lanes" in head
        else:
            assert config.maps.format == "npy"
            assert '"npy": one' in maps_section and "--maps-format scnn-png" in maps_section
        assert "pft" not in text.replace("pft_ablation", "")


def test_a_folder_in_place_of_a_label_file_is_named(sets, tmp_path):
    root = sets / "culane"
    label = sorted((root / "data").rglob("*.lines.txt"))[1]
    label.unlink()
    label.mkdir()  # os.fdopen refused it naming the descriptor: "error: 4: Is a directory"
    one_line(run_cli(*run_args(root, tmp_path / "o")), str(label), "is a folder, not a file")


@pytest.mark.parametrize("name", ["all", "ego"])
def test_a_category_list_named_like_a_tables_own_row_is_refused(sets, tmp_path, name):
    # A list test9_all.txt would be one more "all" row beside the one over every frame (the
    # category figure then failed with a traceback); "ego" likewise beside the ego lanes' row.
    data = sets / "culane" / "data"
    split = data / "list" / "test_split"
    (split / f"test9_{name}.txt").write_text(sorted(split.glob("*.txt"))[0].read_text())
    line = one_line(run_cli("run", "--data-root", str(data), "--maps-root", str(sets / "culane" / "maps"),
                            "--out", str(tmp_path / "out"), "--quiet"),
                    f"test9_{name}.txt", f"cannot be called '{name}'", "rename the file")
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir()), line
