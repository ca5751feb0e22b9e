"""The full command on the real CULane clip, against the independently computed reference accuracy."""

import json

import pandas as pd
from click.testing import CliRunner

from roneld_eval.cli import main


def test_full_run_matches_reference_accuracy(real_clip, real_clip_tree, tmp_path):
    data, maps = real_clip_tree
    # The reference's drawing conventions: int(16*h/288) and int(30*h/288) px (19 and 36 on
    # these 976x351 maps) and predictions truncated to pixels as the RONELD code draws them.
    result = CliRunner().invoke(main, [
        "run", "--dataset", "culane", "--data-root", str(data), "--maps-root", str(maps),
        "--maps-format", "scnn-png", "--pft-ablation", "--save-lanes", "--quiet", "--workers", "1",
        "--set", "paper.thickness_rule=height", "--set", "paper.prediction_rounding=truncate",
        "--out", str(tmp_path / "out"),
    ])
    assert result.exit_code == 0, result.output
    reference = json.loads((real_clip / "reference_accuracy.json").read_text())
    accuracy = pd.read_csv(tmp_path / "out" / "accuracy.csv", dtype={"threshold": str})
    names = {"baseline": "baseline", "roneld": "roneld", "roneld-nopft": "roneld_nopft"}
    worst = 0.0
    for row in accuracy.itertuples():
        expected = reference[names[row.method]]
        assert row.n_gt == expected["n_gt"] == 156
        worst = max(worst, abs(row.accuracy - expected["acc"][row.threshold]))
    assert worst <= 0.01
    lanes = list((tmp_path / "out" / "lanes" / "roneld").rglob("*.lines.txt"))
    assert len(lanes) == 90
