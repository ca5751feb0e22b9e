"""The paired clip bootstrap computed in a run's small memory equals the obvious computation:
each row's clip found by its folder, and every resample drawn at once."""

from __future__ import annotations

import posixpath

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from roneld_eval.thresholds import parse_thresholds
from roneld_eval.metrics import bootstrap
from roneld_eval.metrics.bootstrap import clip_positions, count_clips, paired_bootstrap

FRAMES = st.lists(st.sampled_from([f"d/{video}.MP4/{frame:05d}.jpg" for video in "abcde" for frame in range(3)]
                                  + ["00000.jpg", "x/y/z.png"]), max_size=40)


@settings(max_examples=100, deadline=None)
@given(FRAMES)
def test_clip_positions_are_each_rows_folder_among_the_sorted_folders(frames):
    positions, clips = clip_positions(pd.Series(frames, dtype=object))
    folders = [posixpath.dirname(frame) for frame in frames]
    assert clips == sorted(set(folders))
    assert positions.tolist() == [clips.index(folder) for folder in folders]


def per_frame(n_clips: int, seed: int, shuffled: bool = False) -> pd.DataFrame:
    rng = np.random.default_rng(seed)
    rows = []
    for clip in range(n_clips):
        for frame in range(int(rng.integers(1, 4))):
            for side in ("left", "right"):
                for method in ("baseline", "roneld"):
                    rows.append((f"driver_{clip}/v.MP4/{frame:05d}.jpg", side, method, float(rng.random())))
    table = pd.DataFrame(rows, columns=["frame", "side", "method", "iou"])
    return table.sample(frac=1, random_state=seed).reset_index(drop=True) if shuffled else table


@pytest.mark.parametrize("resamples", [2000, 250, 99])
def test_resampling_in_blocks_draws_what_one_block_draws(monkeypatch, resamples):
    table = per_frame(60, seed=resamples)
    thresholds = parse_thresholds("0.30:0.50:0.01")
    blocked = paired_bootstrap(table, thresholds, "baseline", resamples=resamples)
    monkeypatch.setattr(bootstrap, "RESAMPLE_BLOCK", resamples)  # every resample in one block
    whole = paired_bootstrap(table, thresholds, "baseline", resamples=resamples)
    pd.testing.assert_frame_equal(blocked, whole, check_exact=True)
    assert blocked["ci_low"].notna().all()


def test_the_order_of_rows_does_not_change_the_interval():
    thresholds = parse_thresholds("0.30:0.50:0.05")
    grouped, shuffled = per_frame(30, seed=3), per_frame(30, seed=3, shuffled=True)
    assert count_clips(grouped) == count_clips(shuffled) == 30
    pd.testing.assert_frame_equal(paired_bootstrap(grouped, thresholds, "baseline"),
                                  paired_bootstrap(shuffled, thresholds, "baseline"), check_exact=True)
