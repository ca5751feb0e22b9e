"""Where a benchmark's name becomes its object (roneld_eval.resolve): what a configuration leaves
to its benchmark is filled in where work enters, a problem still names the file it comes from,
and every public function taking a dataset refuses what names none in one line."""

from __future__ import annotations

import pytest
from click.testing import CliRunner
from test_input_checks import built_config, one_line, run_cli

import roneld_eval
from roneld_eval import api
from roneld_eval.cli import main
from roneld_eval.config import EvalConfig
from roneld_eval.errors import ConfigError
from roneld_eval.extract import RoneldTracker
from roneld_eval.resolve import configured


def write(path, text: str):
    path.write_text(text, encoding="utf-8")
    return path


def test_a_file_without_its_benchmarks_facts_gets_them_where_work_enters(tmp_path):
    path = write(tmp_path / "nosize.toml", "[roneld]\nlane_ratio = 0.0\n")
    config = EvalConfig.from_toml(path)
    assert (config.dataset.name, config.dataset.image_width) == ("", 0)
    with pytest.raises(ConfigError, match="gives no image size"):
        _ = config.geometry
    filled, benchmark = configured(config)
    assert (filled.dataset.name, filled.dataset.image_width, filled.dataset.image_height) == ("culane", 1640, 590)
    assert benchmark.name == "culane"
    # RoneldTracker.from_preset, on a vehicle: the file's benchmark's size, or the camera's
    assert RoneldTracker.from_preset(str(path), warm=False).geometry.image_size == (1640, 590)
    assert RoneldTracker.from_preset(str(path), image_size=(1280, 720), warm=False).geometry.image_size == (1280, 720)


@pytest.mark.parametrize("text, said", [
    ('[dataset]\nname = "bogus"\n', "dataset must be one of"),
    ("[maps]\ncrop_bottom_px = 700\n", "crop_bottom_px 700 is below the 590-row image"),
])
def test_a_problem_found_once_the_facts_are_filled_in_names_the_file(tmp_path, text, said):
    path = write(tmp_path / "c.toml", text)
    with pytest.raises(ConfigError) as caught:
        roneld_eval.run(EvalConfig.from_toml(path), tmp_path / "out", progress=False)
    assert str(caught.value).startswith(f"{path}: ") and said in str(caught.value)
    with pytest.raises(ConfigError, match=f"^{path}: "):
        RoneldTracker.from_preset(str(path), warm=False)
    one_line(run_cli("run", "--config", str(path), "--out", str(tmp_path / "o")), f"{path}: ", said)


def test_show_names_a_run_folders_config_toml(fixture_run, tmp_path):
    import shutil

    _, run = fixture_run
    copy = tmp_path / "run"
    shutil.copytree(run, copy)
    text = (copy / "config.toml").read_text()
    write(copy / "config.toml", text.replace('name = "culane"', 'name = "bogus"'))
    one_line(CliRunner().invoke(main, ["show", "--run", str(copy), "--worst", "1"]), f"{copy / 'config.toml'}: ",
             "dataset must be one of")


@pytest.mark.parametrize("dataset", [None, "", 5])
def test_a_public_function_given_no_benchmark_says_so_in_one_line(tmp_path, dataset):
    """None, "" and 5 used to be 'unknown dataset'; for a while they were an AttributeError, or culane."""
    calls = [lambda: roneld_eval.read_dataset(dataset, tmp_path), lambda: roneld_eval.synthesize(dataset, tmp_path),
             lambda: api.fixture_roots(dataset), lambda: roneld_eval.score(dataset, tmp_path, tmp_path),
             lambda: roneld_eval.metric(dataset)]
    for call in calls:
        with pytest.raises(ConfigError, match="unknown dataset"):
            call()


def test_dataset_and_set_choose_the_benchmark_of_a_file_that_names_none(monkeypatch, tmp_path):
    path = write(tmp_path / "nods.toml", "[roneld]\nlane_ratio = 0.6\n")
    for args in (["--dataset", "tusimple"], ["--set", "dataset.name=tusimple"]):
        config = built_config(monkeypatch, tmp_path, "--config", str(path), *args)
        assert (config.dataset.name, config.dataset.image_width, config.dataset.image_height) == ("tusimple", 1280, 720)
        # what the file leaves out is TuSimple's preset's, not CULane's rows (a first-time user's wrong numbers)
        assert config.baseline.rows == EvalConfig.preset("scnn-tusimple").baseline.rows, args
    named = write(tmp_path / "named.toml", '[dataset]\nname = "culane"\n')
    one_line(run_cli("run", "--config", str(named), "--dataset", "tusimple"), "contradicts the config's dataset")


def test_a_bad_set_value_is_not_said_to_be_in_the_default_preset(tmp_path):
    line = one_line(run_cli("run", "--set", "dataset.name=foo", "--out", str(tmp_path)), "dataset must be one of")
    assert ".toml" not in line


def test_the_diagnose_hint_names_the_benchmark_the_run_would_score(tmp_path):
    one_line(run_cli("run", "--diagnose", "--executor", "dask", "--set", "dataset.name=", "--out", str(tmp_path)),
             "`roneld-eval score culane --diagnose`")
