"""VIL-100's Acc/FP/FN in both versions and MMA-Net's instance-mask predictions, against the
official scripts run unchanged: golden values in tests/golden/vil100/acc_cases/expected.json
(MMA-Net 8f95908 evaluate_acc.py, RVLD 4d90de1 evaluate_acc.py) and png2txt/
(generate_iou_pred_txt.py); the real ground truth where ../shared is present."""

from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import example, given, settings
from hypothesis import strategies as st

from roneld_eval.benchmarks.vil100.score import _score_sequence, score_vil100
from roneld_eval.cli import main
from roneld_eval.benchmarks.vil100.reader import read_vil100
from roneld_eval.benchmarks.vil100.maps_png import (GREY_WEIGHTS, colour_greys, instance_lanes, lines_text, lit_pixels,
                                             read_instance_png)
from roneld_eval.errors import InputError
from roneld_eval.lanes_io import read_lines_txt
from roneld_eval.benchmarks.vil100.acc import mmanet_frame, rvld_frame
from roneld_eval.model import Lane

GOLDEN = Path(__file__).parent / "golden" / "vil100"
CASES = GOLDEN / "acc_cases"
EXPECTED = json.loads((CASES / "expected.json").read_text())
PNG2TXT = GOLDEN / "png2txt"
MANIFEST = json.loads((PNG2TXT / "manifest.json").read_text())
SHARED = Path(__file__).resolve().parents[2] / "shared" / "data" / "vil100"


def _case_frames(pred_root: Path, pred_format: str) -> dict:
    dataset = read_vil100(CASES / "anno_txt", CASES / "test.txt", sizes_file=CASES / "test_sizes.json")
    out = {}
    for sequence, frames in dataset.sequences.items():
        piece = _score_sequence((frames, dataset.labels, (pred_root,), *dataset.sizes[sequence], 30, False,
                                 pred_format, None))
        for relpath, (rvld, mmanet) in zip(frames, piece.acc[0]):
            out[relpath] = rvld if mmanet is None else mmanet
    return out


@pytest.mark.parametrize("version, root, pred_format", [("mmanet", "pred_png", "png"), ("rvld", "pred_txt", "lines")])
def test_every_frame_equals_the_official_script(version, root, pred_format):
    # Invented frames reaching every branch: > 8 lanes (accuracy 1.125), negative x, frames without
    # ground truth (accuracy 0), a prediction found by two lanes (FP -1), part-covered lanes.
    frames = _case_frames(CASES / root, pred_format)
    assert set(frames) == set(EXPECTED["frames"])
    for relpath, expected in EXPECTED["frames"].items():
        got = frames[relpath]
        assert [got.accuracy, got.fp, got.fn] == expected[version], (relpath, expected["description"])


def test_the_totals_and_acc_csv_equal_the_scripts(tmp_path):
    score = score_vil100(CASES / "anno_txt", {"syn": CASES / "pred_png"}, list_file=CASES / "test.txt",
                         sizes_file=CASES / "test_sizes.json", pred_format="png", temporal=False, out=tmp_path / "o")
    mmanet = score.acc_overall[("syn", "mmanet")]
    official = EXPECTED["totals"]["mmanet"]
    assert (mmanet.accuracy, mmanet.fp, mmanet.fn) == (official["accuracy"], official["fp"], official["fn"])
    lines = score_vil100(CASES / "anno_txt", {"syn": CASES / "pred_txt"}, list_file=CASES / "test.txt",
                         sizes_file=CASES / "test_sizes.json", temporal=False)
    rvld = lines.acc_overall[("syn", "rvld")]
    official = EXPECTED["totals"]["rvld"]
    assert (rvld.accuracy, rvld.fp, rvld.fn) == (official["acc"], official["fp"], official["fn"])
    assert ("syn", "mmanet") not in lines.acc_overall  # MMA-Net's version reads instance masks only
    text = (tmp_path / "o" / "acc.csv").read_text().splitlines()
    assert text[0] == "method,category,version,frames,accuracy,fp,fn,stopping_lanes"
    mmanet = EXPECTED["totals"]["mmanet"]  # as evaluate_acc.py computes them, to the last bit
    assert f"syn,all,mmanet,11,{mmanet['accuracy']!r},{mmanet['fp']!r},{mmanet['fn']!r},0" in text
    assert "syn,all,mmanet,11,0.6802507836990596,0.045454545454545456,0.1590909090909091,0" in text
    summary = (tmp_path / "o" / "summary.csv").read_text().splitlines()
    assert summary[0].endswith(",acc_mmanet,fp_mmanet,fn_mmanet,acc_rvld,fp_rvld,fn_rvld")
    assert "Acc (MMA-Net) (%)" in (tmp_path / "o" / "summary.md").read_text()


# RVLD's evaluate_acc.py only ever reads what its writer wrote: dongkwonjin/RVLD 4d90de1,
# Modeling/VIL-100/PLD/code/libs/save_prediction.py, Save_Prediction_for_eval_acc.get_2D_lane_points,
# samples each lane at distinct rows (py_coord) and drops one of 3 points or fewer (`if len(pts) <= 3:
# continue`); its cubic interp1d would raise on either. Other lane files go through that rule first.

def test_a_lane_repeating_a_y_keeps_its_first_point_at_each_y():
    truth = [Lane.from_xy(np.linspace(500, 600, 30), np.linspace(500, 1000, 30))]
    repeated = Lane.from_xy(np.r_[np.linspace(500, 600, 30), 900.0], np.r_[np.linspace(500, 1000, 30), 500.0])
    frame = rvld_frame([repeated], truth)  # the script: "Expect x to not have duplicates"
    assert (frame.accuracy, frame.fp, frame.fn, frame.stopping) == (1.0, 0.0, 0.0, 1)


def test_a_lane_of_three_points_or_fewer_is_no_prediction_as_rvlds_writer_drops_it():
    truth = [Lane.from_xy(np.linspace(500, 600, 30), np.linspace(500, 1000, 30))]
    found = Lane.from_xy(np.linspace(500, 600, 30), np.linspace(500, 1000, 30))
    short = Lane.from_xy([500, 520, 540], [500, 700, 900])
    blank = Lane(np.zeros((0, 2)))  # a blank line of a .lines.txt
    frame = rvld_frame([short], truth)  # counted as a prediction before: FP 1
    assert (frame.accuracy, frame.fp, frame.fn, frame.stopping) == (0.0, 0.0, 1.0, 1)
    frame = rvld_frame([blank, short, found, short], truth)  # FP 0.75 before
    assert (frame.accuracy, frame.fp, frame.fn, frame.stopping) == (1.0, 0.0, 0.0, 2)
    # two points at one y leave 3: not written either
    frame = rvld_frame([Lane.from_xy([500, 510, 520, 530], [500, 500, 700, 900])], truth)
    assert (frame.accuracy, frame.fp, frame.fn, frame.stopping) == (0.0, 0.0, 1.0, 1)


def test_a_short_lane_far_away_does_not_find_a_near_horizontal_lane():
    # Without a fit a lane was x = -2 on every row, -100 in line_accuracy: within 20 / cos(atan 20)
    # = 400 px of every x of this nearly horizontal lane (x 0..200 over 10 rows), so it was found.
    truth = [Lane.from_xy(np.linspace(0, 200, 11), np.linspace(500, 510, 11))]
    far = Lane.from_xy([1500, 1510, 1520], [800, 900, 1000])
    frame = rvld_frame([far], truth)
    assert (frame.accuracy, frame.fp, frame.fn, frame.stopping) == (0.0, 0.0, 1.0, 1)


def test_short_lanes_and_blank_lines_leave_the_rvld_scripts_totals(tmp_path):
    # The golden's lanes as RVLD's writer wrote them, plus what it never writes (a blank line, lanes of
    # 1 to 3 points): the script's totals on the golden stay the totals.
    pred = tmp_path / "pred_txt"
    shutil.copytree(CASES / "pred_txt", pred)
    for path in sorted(pred.rglob("*.lines.txt"))[::3]:
        path.write_text(path.read_text() + "\n700 900\n10 1000 12 1030\n1900 500 1910 520 1915 540\n")
    lines = score_vil100(CASES / "anno_txt", {"syn": pred}, list_file=CASES / "test.txt",
                         sizes_file=CASES / "test_sizes.json", temporal=False)
    rvld = lines.acc_overall[("syn", "rvld")]
    official = EXPECTED["totals"]["rvld"]
    assert (rvld.accuracy, rvld.fp, rvld.fn) == (official["acc"], official["fp"], official["fn"])
    assert rvld.stopping == 3 * len(sorted(pred.rglob("*.lines.txt"))[::3])


def test_the_writers_rule_is_said_beside_rvlds_acc(tmp_path):
    result = CliRunner().invoke(main, ["score", "vil100", "--labels", str(CASES / "anno_txt"), "--pred-root",
                                       str(CASES / "pred_txt"), "--sizes", str(CASES / "test_sizes.json"),
                                       "--no-temporal", "--workers", "1", "--out", str(tmp_path / "o")])
    assert result.exit_code == 0, result.output
    said = "a lane of 3 points or fewer (a blank line too) is no prediction"
    assert "Acc (RVLD) (%)" in result.output and said in result.output.split("Acc (RVLD) (%)")[1]
    summary = (tmp_path / "o" / "summary.md").read_text()
    assert "libs/save_prediction.py, 4d90de1" in summary and said in summary
    assert "matches no point here" not in summary  # it did not: it was a prediction that found nothing


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 40), st.integers(1, 40), st.floats(0, 1), st.integers(0, 2**32 - 1), st.booleans())
def test_lit_pixels_are_numpys_nonzero_in_its_order(height, width, lit, seed, colours):
    # The pixel order decides each lane's fit to the last bit: it must be np.where's.
    random = np.random.default_rng(seed)
    grey = (random.random((height, width)) < lit) * random.integers(1, 256, (height, width))
    grey = grey * 0.0125 if colours else grey.astype(np.uint8)
    rows, columns = lit_pixels(grey)
    expected_rows, expected_columns = np.nonzero(grey > 0)
    assert rows.tolist() == expected_rows.tolist() and columns.tolist() == expected_columns.tolist()
    assert rows.dtype == expected_rows.dtype


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 30), st.integers(1, 30), st.integers(1, 12), st.integers(0, 2**32 - 1), st.floats(0, 1))
@example(1, 2, 1, 15, 0.0)  # a grey one bit off the same product on np.unique's array, in a CI run
def test_colour_greys_are_rgb2grays_of_every_pixel(height, width, colours, seed, black):
    # Found among the lit pixels alone (3 s a full-HD mask before). What makes the lanes: one grey
    # per colour, black's 0, the colours in the same grey order as rgb2gray's. The greys themselves
    # may differ from the same product on another array in the last bit (OpenBLAS gives a row of a
    # (k, 3) @ (3,) product by k and alignment: seen once in a CI run), as rgb2gray's own on the
    # whole image may: at most 1 ulp.
    random = np.random.default_rng(seed)
    palette = random.integers(0, 256, (colours, 3), dtype=np.uint8)
    palette[random.random(colours) < 0.3, random.integers(0, 3)] = 0  # colours sharing a zero channel
    pixels = palette[random.integers(0, colours, (height, width))]
    pixels[random.random((height, width)) < black] = 0
    unique, inverse = np.unique(pixels.reshape(-1, 3), axis=0, return_inverse=True)
    expected = (np.multiply(unique, 1.0 / 255, dtype=np.float64) @ np.array(GREY_WEIGHTS))[inverse.reshape(-1)]
    greys = colour_greys(pixels).reshape(-1)
    np.testing.assert_array_max_ulp(greys, expected, maxulp=1)
    assert (greys == 0).tolist() == (pixels.reshape(-1, 3) == 0).all(axis=1).tolist()
    _, ours = np.unique(greys, return_inverse=True)
    _, theirs = np.unique(expected, return_inverse=True)
    assert ours.tolist() == theirs.tolist()  # the same lanes, in the same order


@settings(max_examples=200, deadline=None, derandomize=True)
@given(st.integers(1, 40_000), st.integers(1, 2200), st.integers(1, 3), st.integers(0, 2**32 - 1))
def test_the_quadratic_fit_is_np_polyfits_to_the_last_bit(pixels, rows, columns_per_row, seed):
    # One row (rank 2, polyfit's RankWarning), two rows, and lanes of every length up to a
    # full-HD mask's (35,203 pixels the most among the real test set's, drawn 30 px wide), in the
    # pixel order np.where gives: the fit decides every written x.
    import warnings

    from roneld_eval.benchmarks.vil100.maps_png import quadratic_fit

    random = np.random.default_rng(seed)
    ys = np.sort(random.integers(0, rows, pixels) + 1)  # above the bottom row: polyfit's scale is not 0
    xs = random.integers(1, 1921, pixels) // columns_per_row
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        expected = np.polyfit(ys, xs, 2)
    assert quadratic_fit(ys, xs).tobytes() == expected.tobytes()


def test_a_fit_of_no_pixel_is_refused_as_np_polyfit_refuses_it():
    from roneld_eval.benchmarks.vil100.maps_png import quadratic_fit

    none = np.zeros(0, np.intp)
    with pytest.raises(TypeError) as ours:
        quadratic_fit(none, none)
    with pytest.raises(TypeError) as numpys:
        np.polyfit(none, none, 2)
    assert str(ours.value) == str(numpys.value)


def _pillows_greys(path: Path) -> np.ndarray:
    """What Pillow alone gives (the reading before masks were decoded here)."""
    from PIL import Image

    with Image.open(path) as opened:
        if opened.mode == "L":
            return np.asarray(opened)
        return colour_greys(np.asarray(opened.convert("RGB")))


@settings(max_examples=80, deadline=None, derandomize=True)
@given(st.integers(1, 60), st.integers(1, 90), st.integers(1, 12), st.integers(0, 2**32 - 1),
       st.sampled_from(["opencv grey", "pillow palette", "pillow small palette", "pillow grey", "pillow palette "
                        "with transparency", "pillow palette past its colours"]))
def test_masks_decoded_here_are_pillows_pixels(tmp_path_factory, height, width, lanes, seed, writer):
    # OpenCV's grey masks (rows filtered None or Sub) and Pillow's palette masks (MMA-Net's) are
    # decoded by the maps' PNG kernel; every other PNG still by Pillow, which refuses what it did.
    from PIL import Image

    from roneld_eval.benchmarks.vil100.maps_png import _grey_image, _plain_pixels

    random = np.random.default_rng(seed)
    mask = (random.integers(0, lanes + 1, (height, width)) * (random.random((height, width)) < 0.3)).astype(np.uint8)
    path = tmp_path_factory.mktemp("mask") / "m.png"
    if writer == "opencv grey":
        cv2.imwrite(str(path), mask)
    elif writer == "pillow grey":  # adaptive filters (Up, Paeth): Pillow's
        Image.fromarray(mask).save(path)
    else:
        image = Image.fromarray(mask, "L").convert("P")
        colours = random.integers(0, 256, 256 * 3).tolist()
        image.putpalette(colours[:3 * (lanes + 1)] if writer == "pillow small palette" else colours)
        if writer.endswith("past its colours"):  # 20 colours (8 bits a pixel), an index of 30
            image.putpalette(colours[:60])
            image.putpixel((0, 0), 30)
        info = {"transparency": 0} if writer.endswith("transparency") else {}
        image.save(path, **info)
    fast = _plain_pixels(path, width, height)
    if writer in ("opencv grey", "pillow palette"):
        assert fast is not None
    if writer.endswith(("transparency", "past its colours")):
        assert fast is None
    if writer.endswith("transparency"):
        assert fast is None
        with pytest.raises(InputError, match="with transparency"):
            _grey_image(path)
        return
    expected = _pillows_greys(path)
    got = _grey_image(path)
    assert got.dtype == expected.dtype and np.array_equal(got, expected)
    if fast is not None:
        assert np.array_equal(fast, expected)


def test_a_mask_lane_whose_fit_fails_matches_nothing(tmp_path):
    mask = np.zeros((480, 960), np.uint8)
    mask[479, 100:300] = 1  # every pixel in the bottom row: np.polyfit raises, the scripts stop
    mask[200:400, 500] = 2
    path = tmp_path / "m.png"
    cv2.imwrite(str(path), mask)
    lanes, _, _ = instance_lanes(path)
    assert lanes[0].fit is None and lanes[1].fit is not None
    read = read_instance_png(path)
    assert len(read.lanes) == 1  # the failing lane writes nothing (one row: no samples)
    frame = mmanet_frame(read.fits, [Lane.from_xy([500] * 20, np.linspace(80, 280, 20))], 480)
    assert (frame.accuracy, frame.fp, frame.fn, frame.stopping) == (1.0, 0.5, 0.0, 1)  # 2 predictions, 1 found


@pytest.mark.parametrize("pair", MANIFEST["pairs"], ids=[p["key"] for p in MANIFEST["pairs"]])
def test_masks_become_the_lines_generate_iou_pred_txt_writes(pair):
    # The script names its output after the JSON at the same sorted index (D_: a gap in the PNGs
    # shifts them); the text of each mask is compared here.
    lanes, width, height = instance_lanes(PNG2TXT / pair["input_png"])
    assert (width, height) == (pair["width"], pair["height"])
    ours, theirs = lines_text(lanes, width, height), (PNG2TXT / pair["output_txt"]).read_text()
    if ours != theirs:
        _differ_only_in_lapacks_last_bits(lanes, ours, theirs, pair["description"])


def _differ_only_in_lapacks_last_bits(lanes, ours: str, theirs: str, description: str) -> None:
    """A vertical lane's fitted x is an integer plus or minus LAPACK's rounding, which differs
    between machines (OpenBLAS picks its kernels by CPU): np.polyfit gives 1000.9999999999999
    on one and 1001.0000000000002 on another, and the script's %d writes 1000 or 1001. The
    script run here writes what we write; against the golden text only those x may differ, by one."""
    from roneld_eval.benchmarks.vil100.maps_png import Y_STEP

    near_integer = set()
    for lane in lanes:
        if lane.fit is None:
            continue
        ys = np.arange(int(lane.ys.min()), int(lane.ys.max()), Y_STEP, dtype=np.float64)
        xs = lane.fit[0] * ys * ys + lane.fit[1] * ys + lane.fit[2]
        near_integer |= {int(round(x)) for x in xs.tolist() if abs(x - round(x)) < 1e-6}
    ours_lines, theirs_lines = ours.splitlines(), theirs.splitlines()
    assert len(ours_lines) == len(theirs_lines), description
    for a, b in zip(ours_lines, theirs_lines):
        left, right = a.split(), b.split()
        assert len(left) == len(right) and left[1::2] == right[1::2], description  # the same rows
        for x, y in zip(left[::2], right[::2]):
            assert x == y or (abs(int(x) - int(y)) == 1 and max(int(x), int(y)) in near_integer), (description, x, y)


def test_a_mask_that_reading_does_not_define_is_refused(tmp_path):
    rgba = np.zeros((20, 30, 4), np.uint8)
    rgba[5:10, 5:20] = (9, 9, 9, 128)
    cv2.imwrite(str(tmp_path / "a.png"), rgba)
    with pytest.raises(InputError, match="transparent pixels"):
        instance_lanes(tmp_path / "a.png")
    cv2.imwrite(str(tmp_path / "b.png"), np.zeros((20, 30), np.uint16) + 700)
    with pytest.raises(InputError, match="mode I;16"):
        instance_lanes(tmp_path / "b.png")
    (tmp_path / "c.png").write_bytes(b"\x89PNG\r\n\x1a\n" + b"\0" * 40)
    with pytest.raises(InputError):
        instance_lanes(tmp_path / "c.png")


def test_score_vil100_reads_instance_masks_from_the_command_line(tmp_path):
    result = CliRunner().invoke(main, ["score", "vil100", "--labels", str(CASES / "anno_txt"), "--pred-root",
                                       str(CASES / "pred_png"), "--pred-format", "png", "--sizes",
                                       str(CASES / "test_sizes.json"), "--out", str(tmp_path / "o"), "--quiet"])
    assert result.exit_code == 0, result.output
    assert (tmp_path / "o" / "acc.csv").is_file()
    result = CliRunner().invoke(main, ["score", "vil100", "--labels", str(CASES / "anno_txt"), "--pred-root",
                                       str(CASES / "pred_txt"), "--pred-format", "png", "--sizes",
                                       str(CASES / "test_sizes.json")])
    assert result.exit_code == 2 and "no prediction file of the list is here" in result.output
    assert ".png" in result.output


def _render_masks(labels: Path, out: Path, sizes: dict) -> None:
    """The ground truth as instance masks, as the golden harness drew them: lane k of a file with
    value k, cv2.polylines of its rounded points, round(30 W / 1920) px wide."""
    for path in sorted(labels.rglob("*.lines.txt")):
        relative = path.relative_to(labels)
        width, height = sizes[relative.parts[0]]["width"], sizes[relative.parts[0]]["height"]
        mask = np.zeros((height, width), np.uint8)
        for k, lane in enumerate(read_lines_txt(path)):
            if len(lane.points):
                points = np.round(lane.points).astype(np.int32).reshape(-1, 1, 2)
                cv2.polylines(mask, [points], False, k + 1, thickness=max(1, round(30 * width / 1920)))
        target = out / relative.parent / (relative.name[:-len(".lines.txt")] + ".png")
        target.parent.mkdir(parents=True, exist_ok=True)
        cv2.imwrite(str(target), mask)


@pytest.mark.long
@pytest.mark.skipif(not SHARED.is_dir(), reason="needs ../shared/data/vil100")
def test_the_real_ground_truth_as_masks_scores_as_mmanets_script(tmp_path):
    # The value of MMA-Net's script run unchanged on these same inputs (the 2,000 test frames):
    # the ground truth drawn as masks. RVLD's on the ground truth's lanes is checked where they
    # are scored against themselves (test_vil100.py).
    sizes = json.loads((SHARED / "test_sizes.json").read_text())
    _render_masks(SHARED / "anno_txt", tmp_path / "png", sizes)
    masks = score_vil100(SHARED / "anno_txt", {"gt": tmp_path / "png"}, pred_format="png",
                         list_file=SHARED / "test.txt", sizes_file=SHARED / "test_sizes.json", temporal=False,
                         workers=2)
    mmanet = masks.acc_overall[("gt", "mmanet")]
    assert (mmanet.accuracy, mmanet.fp, mmanet.fn, mmanet.frames) == (0.9799749931343438, 0.0, 0.0, 2000)
    assert not math.isnan(masks.overall[("gt", "0.50")].miou)


def _png_header(width: int, height: int) -> bytes:
    import struct
    import zlib

    body = b"IHDR" + struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + struct.pack(">I", 13) + body + struct.pack(">I", zlib.crc32(body))


def test_a_mask_too_large_or_not_a_png_is_refused_before_decoding(tmp_path):
    # 16384 x 16384 passed the side bound and then raised Pillow's DecompressionBombError
    (tmp_path / "big.png").write_bytes(_png_header(16384, 16384) + b"\0" * 64)
    with pytest.raises(InputError, match="at most 16384 px a side and 67,108,864 pixels"):
        instance_lanes(tmp_path / "big.png")
    mask = np.zeros((48, 64, 3), np.uint8)
    mask[10:40, 30:34] = 80
    cv2.imwrite(str(tmp_path / "j.jpg"), mask)
    (tmp_path / "j.png").write_bytes((tmp_path / "j.jpg").read_bytes())  # its artefacts would become lanes
    with pytest.raises(InputError, match="a JPEG image, not a PNG"):
        instance_lanes(tmp_path / "j.png")


def test_masks_of_another_size_and_ground_truth_beyond_the_size_are_said(tmp_path):
    masks = tmp_path / "masks" / "S_cases_1920x1080"
    masks.mkdir(parents=True)
    for path in sorted((CASES / "pred_png" / "S_cases_1920x1080").glob("*.png")):
        image = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
        cv2.imwrite(str(masks / path.name), cv2.resize(image, (960, 540), interpolation=cv2.INTER_NEAREST))
    score = score_vil100(CASES / "anno_txt", {"half": tmp_path / "masks"}, list_file=CASES / "test.txt",
                         sizes_file=CASES / "test_sizes.json", pred_format="png", temporal=False)
    assert any("half: 11 masks of S_cases_1920x1080 are not 1920x1080" in w for w in score.warnings), score.warnings
    (tmp_path / "small.json").write_text('{"S_cases_1920x1080": {"width": 1280, "height": 720}}')
    score = score_vil100(CASES / "anno_txt", {"syn": CASES / "pred_txt"}, list_file=CASES / "test.txt",
                         sizes_file=tmp_path / "small.json", temporal=False)
    assert any("reaches beyond its 1280x720 size" in w and "is the size right?" in w for w in score.warnings)
    right = score_vil100(CASES / "anno_txt", {"syn": CASES / "pred_txt"}, list_file=CASES / "test.txt",
                         sizes_file=CASES / "test_sizes.json", temporal=False)
    assert not right.warnings
