"""Configuration: presets, overrides, TOML round trip, exact thresholds."""

import pytest

from roneld_eval.config import EvalConfig, PaperMetricParams
from roneld_eval.presets import preset_names
from roneld_eval.thresholds import parse_rows, parse_thresholds
from roneld_eval.errors import ConfigError


def test_presets_cover_both_models_and_datasets():
    assert preset_names() == ["enet-sad-culane", "enet-sad-tusimple", "lanes-vil100", "scnn-culane", "scnn-tusimple",
                              "segmentation-llamas"]
    scnn = EvalConfig.preset("scnn-culane")
    assert (scnn.maps.width, scnn.maps.height, scnn.maps.crop_top_px) == (800, 288, 0)
    enet = EvalConfig.preset("enet-sad-culane")
    assert (enet.maps.width, enet.maps.height, enet.maps.crop_top_px, enet.maps.crop_bottom_px) == (976, 208, 240, 590)
    tusimple = EvalConfig.preset("scnn-tusimple")
    assert tusimple.roneld.lane_ratio == 0.6 and tusimple.dataset.image_height == 720
    assert scnn.roneld.lane_ratio == 0.0 and scnn.roneld.center_ratio == 0.5
    vil100 = EvalConfig.preset("lanes-vil100")  # a detector's lane files, each video at its own size
    assert (vil100.maps.format, vil100.maps.crop_bottom_px, vil100.dataset.image_height) == ("lanes", None, 1080)


def test_toml_round_trip(tmp_path):
    config = EvalConfig.preset("enet-sad-tusimple").with_overrides(**{"dataset.limit": 3, "pft_ablation": True})
    path = tmp_path / "c.toml"
    path.write_text(config.to_toml())
    assert EvalConfig.from_toml(path) == config


def test_overrides_ignore_none_and_reject_unknown_keys():
    config = EvalConfig.preset("scnn-culane")
    assert config.with_overrides(**{"dataset.limit": None}) == config
    with pytest.raises(ConfigError, match="unknown setting"):
        config.with_overrides(**{"maps.colour": 1})


def test_unknown_and_mistyped_toml_keys_are_named(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text("[maps]\nwidht = 800\n")
    with pytest.raises(ConfigError, match="unknown key 'widht'"):
        EvalConfig.from_toml(path)
    path.write_text("[maps]\nwidth = 'wide'\n")
    with pytest.raises(ConfigError, match="width must be an integer"):
        EvalConfig.from_toml(path)


def test_pft_ablation_adds_the_method_once():
    config = EvalConfig(pft_ablation=True)
    assert config.methods == ("baseline", "roneld", "roneld-nopft")
    with pytest.raises(ConfigError):
        EvalConfig(methods=("baseline", "baseline"))
    with pytest.raises(ConfigError):
        EvalConfig(methods=("magic",))


def test_thresholds_are_exact_hundredths():
    thresholds = parse_thresholds("0.30:0.50:0.01")
    assert len(thresholds) == 21
    assert thresholds.labels[0] == "0.30" and thresholds.labels[-1] == "0.50"
    assert thresholds.values[0] == 0.3 and repr(thresholds.values[0]) == "0.3"
    assert all(len(repr(v)) <= 4 for v in thresholds.values)  # 0.31, never 0.31000000000000005
    assert [float(label) for label in thresholds.labels] == list(thresholds.values)
    assert parse_thresholds("0.5").values == (0.5,)
    assert parse_thresholds("0.3, 0.5").labels == ("0.30", "0.50")
    with pytest.raises(ConfigError):
        parse_thresholds("0.30:0.50:0.03")
    with pytest.raises(ConfigError):
        parse_thresholds("1.5")


def test_thickness_rules():
    width_rule = PaperMetricParams(thickness_rule="width")
    height_rule = PaperMetricParams(thickness_rule="height")
    assert width_rule.thickness(16, 800, 288) == height_rule.thickness(16, 800, 288) == 16
    assert width_rule.thickness(30, 976, 351) == 37  # round(36.6)
    assert height_rule.thickness(30, 976, 351) == 36  # int(36.56), the RONELD reference
    assert height_rule.thickness(16, 976, 351) == 19
    assert width_rule.thickness(16, 75, 27) == 2  # 1.5 rounds up


def test_lines_thinner_than_two_pixels_are_refused():
    # OpenCV draws thickness 1 as a thin 8-connected line, which the rasteriser does not emulate.
    with pytest.raises(ConfigError, match="is 1 px on 74x27 maps"):
        PaperMetricParams(thickness_rule="width").thickness(16, 74, 27)
    with pytest.raises(ConfigError, match="is 1 px on 976x35 maps"):
        PaperMetricParams(thickness_rule="height").thickness(16, 976, 35)
    for key in ("paper.gt_thickness_px", "paper.pred_thickness_px", "official.lane_width_px"):
        with pytest.raises(ConfigError, match=key.split(".")[1]):
            EvalConfig().with_overrides(**{key: 1})


def test_rows_parse():
    assert list(parse_rows("249:590:20"))[-1] == 589
    assert len(parse_rows("249:590:20")) == 18
    with pytest.raises(ConfigError):
        parse_rows("a:b")


def test_a_deeply_nested_toml_file_is_one_error(tmp_path):
    path = tmp_path / "deep.toml"
    path.write_text("a = " + "[" * 100_000 + "]" * 100_000 + "\n")
    with pytest.raises(ConfigError, match="deep.toml: not a configuration: nested too deeply"):
        EvalConfig.from_toml(path)


def test_a_huge_config_file_is_refused_unread(tmp_path):
    path = tmp_path / "huge.toml"
    with open(path, "wb") as handle:
        handle.truncate(10 * 10**9)
    with pytest.raises(ConfigError, match="huge.toml: too large \\(10,000,000,000 bytes\\)"):
        EvalConfig.from_toml(path)


def test_a_file_of_a_few_settings_keeps_the_rest_of_the_base_preset(tmp_path):
    # A first-time user's my.toml of one setting with --dataset tusimple read CULane's baseline rows (the
    # dataclasses' defaults): baseline accuracy 0.000 instead of 0.500, without a word.
    mine = tmp_path / "my.toml"
    mine.write_text("[roneld]\nlane_ratio = 0.25\n[baseline]\nthreshold = 0.4\n")
    layered = EvalConfig.from_toml_over(mine, "scnn-tusimple")
    preset = EvalConfig.preset("scnn-tusimple")
    assert layered.baseline.rows == preset.baseline.rows != EvalConfig().baseline.rows
    assert (layered.roneld.lane_ratio, layered.baseline.threshold) == (0.25, 0.4)  # the file's own win
    assert layered.roneld.center_ratio == preset.roneld.center_ratio
    assert layered.source == str(mine)
    mine.write_text("[roneld]\nlane_ratio = 7\n")
    with pytest.raises(ConfigError, match=f"^{mine}: roneld.lane_ratio must be in"):
        EvalConfig.from_toml_over(mine, "scnn-tusimple")


def test_run_reads_a_partial_config_file_over_its_datasets_preset(tmp_path):
    from click.testing import CliRunner

    from roneld_eval.benchmarks.tusimple.synth import synth_tusimple
    from roneld_eval.cli import main

    made = synth_tusimple(tmp_path / "t", clips=2, frames=10, seed=1)
    (tmp_path / "my.toml").write_text("[roneld]\nlane_ratio = 0.6\n")  # what scnn-tusimple says too
    for name, config in (("mine", ["--config", str(tmp_path / "my.toml"), "--dataset", "tusimple"]),
                         ("preset", ["--config", "scnn-tusimple"])):
        done = CliRunner().invoke(main, ["run", *config, "--data-root", str(made.data_root), "--maps-root",
                                         str(made.maps_root), "--out", str(tmp_path / name), "--quiet",
                                         "--workers", "1"])
        assert done.exit_code == 0, done.output
    for table in ("official.csv", "accuracy.csv"):
        assert (tmp_path / "mine" / table).read_bytes() == (tmp_path / "preset" / table).read_bytes()
