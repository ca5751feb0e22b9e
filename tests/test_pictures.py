"""Confidence intervals, pictures and the HTML report."""

import shutil
import subprocess

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from roneld_eval import api
from roneld_eval.cli import main
from roneld_eval.thresholds import parse_thresholds
from roneld_eval.metrics.bootstrap import paired_bootstrap
from roneld_eval.report.overlays import worst_frames

THRESHOLDS = parse_thresholds("0.30:0.50:0.10")


def per_frame_table(rows):
    return pd.DataFrame(rows, columns=["frame", "side", "method", "iou"])


def test_identical_methods_give_a_zero_interval():
    rng = np.random.default_rng(0)
    rows = []
    for clip in range(30):
        for frame in range(5):
            for side in ("left", "right"):
                iou = float(rng.random())
                rows += [(f"c{clip}/{frame}.jpg", side, m, iou) for m in ("baseline", "roneld")]
    gains = paired_bootstrap(per_frame_table(rows), THRESHOLDS, "baseline")
    assert (gains[["difference", "ci_low", "ci_high"]].to_numpy() == 0).all()


def test_a_constant_difference_is_recovered_exactly():
    # In every clip RONELD finds 4 of 4 lanes and the baseline 2 of 4: the difference is 0.5 in
    # every resample, so the interval collapses onto it.
    rows = []
    for clip in range(12):
        for frame in range(2):
            for side, base in (("left", 0.9), ("right", 0.1)):
                name = f"c{clip}/{frame}.jpg"
                rows += [(name, side, "roneld", 0.9), (name, side, "baseline", base)]
    gains = paired_bootstrap(per_frame_table(rows), THRESHOLDS, "baseline")
    np.testing.assert_allclose(gains[["difference", "ci_low", "ci_high"]].to_numpy(), 0.5)


def test_interval_covers_a_known_difference():
    # 400 clips; RONELD is right with probability 0.8, the baseline 0.7, independently:
    # the difference is about 0.1 with a standard error of about sqrt(.16+.21)/sqrt(800) = 0.0215.
    rng = np.random.default_rng(7)
    rows = []
    for clip in range(400):
        for side in ("left", "right"):
            rows.append((f"c{clip}/0.jpg", side, "roneld", 0.9 if rng.random() < 0.8 else 0.1))
            rows.append((f"c{clip}/0.jpg", side, "baseline", 0.9 if rng.random() < 0.7 else 0.1))
    gains = paired_bootstrap(per_frame_table(rows), parse_thresholds("0.5"), "baseline").iloc[0]
    assert gains.ci_low < 0.1 < gains.ci_high
    assert 0.06 < gains.ci_high - gains.ci_low < 0.11  # about 2 x 1.96 x 0.0215
    again = paired_bootstrap(per_frame_table(rows), parse_thresholds("0.5"), "baseline").iloc[0]
    assert (again.ci_low, again.ci_high) == (gains.ci_low, gains.ci_high)  # fixed seed


def test_intervals_appear_in_the_tables(fixture_run):
    result, out = fixture_run
    accuracy = pd.read_csv(out / "accuracy.csv")
    assert {"roneld_gain", "roneld_gain_ci_low", "roneld_gain_ci_high"} <= set(accuracy.columns)
    baseline = accuracy[accuracy["method"] == "baseline"]
    # The fixture has 4 clips, too few for an interval over clips (see test_report_labels for 5+).
    assert baseline["roneld_gain_ci_low"].isna().all() and baseline["roneld_gain_ci_high"].isna().all()
    assert baseline["roneld_gain"].notna().all()
    assert accuracy[accuracy["method"] == "roneld"]["roneld_gain"].isna().all()
    assert "[n/a (4 clips)]" in (out / "accuracy.md").read_text()
    assert "[n/a (4~clips)]" in (out / "accuracy.tex").read_text()


def test_worst_frames_ranks_by_difference():
    rows = per_frame_table([
        ("a.jpg", "left", "baseline", 0.1), ("a.jpg", "left", "roneld", 0.9),
        ("b.jpg", "left", "baseline", 0.5), ("b.jpg", "left", "roneld", 0.6),
        ("c.jpg", "left", "baseline", 0.9), ("c.jpg", "left", "roneld", 0.2),
        ("c.jpg", "right", "baseline", 0.5), ("c.jpg", "right", "roneld", 0.5),
    ])
    assert worst_frames(rows, 2) == ["a.jpg", "c.jpg"]


def test_show_draws_frames_into_its_own_folder(fixture_run, tmp_path):
    _, out = fixture_run
    run_dir = tmp_path / "run"
    shutil.copytree(out, run_dir)
    report = (run_dir / "report.html").read_bytes()
    result = CliRunner().invoke(main, ["show", "--run", str(run_dir), "--worst", "2"])
    assert result.exit_code == 0, result.output
    pictures = sorted((run_dir / "show" / "overlays").glob("*.png"))
    assert len(pictures) == 2 and (run_dir / "show" / "overlays.png").exists()
    assert (run_dir / "report.html").read_bytes() == report  # the run's own files untouched
    import cv2

    image = cv2.imread(str(pictures[0]))
    assert image.shape[1] == 1000 and image.std() > 10
    frame = "driver_100_30frame/05181432_0203.MP4/00030.jpg"
    result = CliRunner().invoke(main, ["show", "--run", str(run_dir), "--frame", frame, "--method", "roneld",
                                       "--out", str(tmp_path / "pictures")])
    assert result.exit_code == 0, result.output
    assert (tmp_path / "pictures" / "overlays" / "driver_100_30frame__05181432_0203.MP4__00030.png").exists()
    result = CliRunner().invoke(main, ["show", "--run", str(run_dir), "--frame", "nowhere/0.jpg"])
    assert result.exit_code == 2 and "not in this run's dataset" in result.output
    # the nearest frame for a path one digit off, and the full path for a bare file name
    result = CliRunner().invoke(main, ["show", "--run", str(run_dir), "--frame", frame.replace("00030", "00031")])
    assert result.exit_code == 2 and f"(did you mean {frame}?)" in result.output, result.output
    result = CliRunner().invoke(main, ["show", "--run", str(run_dir), "--frame", "00030.jpg"])
    assert result.exit_code == 2 and "(did you mean driver_" in result.output and "relative to the dataset root" in \
        result.output, result.output
    result = CliRunner().invoke(main, ["show", "--run", str(tmp_path)])
    assert result.exit_code == 2 and "not a folder written by `roneld-eval run`" in result.output


def test_show_refuses_a_foreign_out_before_drawing_anything(fixture_run, tmp_path, monkeypatch):
    def no_work(*args, **kwargs):
        raise AssertionError("drew before the output folder was checked")

    monkeypatch.setattr(api, "_show_pictures", no_work)
    _, run_dir = fixture_run
    out = tmp_path / "thesis"
    out.mkdir()
    (out / "thesis.tex").write_text("mine")
    result = CliRunner().invoke(main, ["show", "--run", str(run_dir), "--worst", "2", "--out", str(out)])
    assert result.exit_code == 2 and result.output.count("\n") == 1, result.output
    assert "holds files roneld-eval did not write (thesis.tex)" in result.output
    assert [p.name for p in out.iterdir()] == ["thesis.tex"]


def test_run_with_overlays_and_categories(tmp_path):
    api.run(api.default_config("culane").with_overrides(workers=1), tmp_path, progress=False, overlays=3)
    assert len(list((tmp_path / "overlays").glob("*.png"))) == 3
    categories = pd.read_csv(tmp_path / "categories.csv")
    assert set(categories["category"]) == {"normal", "crowd", "shadow", "curve", "all"}
    assert (tmp_path / "categories.png").exists()


def test_report_renders_in_chromium(fixture_run, tmp_path):
    chromium = shutil.which("chromium") or shutil.which("chromium-browser") or shutil.which("google-chrome")
    if chromium is None:
        pytest.skip("Chromium is not installed")
    _, out = fixture_run
    flags = [chromium, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
             "--disable-background-networking", "--disable-component-update", "--disable-sync",
             f"--user-data-dir={tmp_path / 'profile'}"]
    url = (out / "report.html").resolve().as_uri()
    dom = subprocess.run(flags + ["--dump-dom", url], capture_output=True, text=True, timeout=120).stdout
    assert "roneld-eval: SCNN on CULane" in dom and dom.count("<table") >= 4
    shot = tmp_path / "page.png"
    subprocess.run(flags + ["--window-size=1200,2400", f"--screenshot={shot}", url], capture_output=True, timeout=120)
    import cv2

    image = cv2.imread(str(shot))
    assert image is not None and (image < 200).mean() > 0.02  # text, tables and figures, not a blank page


def test_the_contact_sheet_has_one_legend_above_its_pictures(fixture_run, tmp_path):
    import cv2

    _, run_dir = fixture_run
    result = CliRunner().invoke(main, ["show", "--run", str(run_dir), "--worst", "4", "--out", str(tmp_path / "show")])
    assert result.exit_code == 0, result.output
    pictures = [cv2.imread(str(path)) for path in sorted((tmp_path / "show" / "overlays").glob("*.png"))]
    sheet = cv2.imread(str(tmp_path / "show" / "overlays.png"))
    gap, cell, width = 8, pictures[0].shape[0], pictures[0].shape[1]
    legend_height = sheet.shape[0] - (2 * (cell + gap) + gap)
    assert legend_height > 0 and (sheet[:legend_height] < 128).any()  # the legend, drawn once, on top
    legend_zone = 24 * 5 + 12  # the legend's rows in a picture of its own (5 lines of 24 px)
    for k in range(4):
        r, c = divmod(k, 2)
        y, x = legend_height + gap + r * (cell + gap), gap + c * (width + gap)
        panel = sheet[y:y + cell, x:x + width]
        same = [p for p in pictures if np.array_equal(p[legend_zone:], panel[legend_zone:])]
        assert len(same) == 1  # each picture in the sheet as drawn, below the legend's rows
        assert not np.array_equal(same[0][:legend_zone], panel[:legend_zone])  # and without a legend of its own


def _ink_lines(rows: np.ndarray) -> list[int]:
    """Heights of the runs of rows holding dark text, top to bottom."""
    heights, run = [], 0
    for inked in (rows.min(axis=(1, 2)) < 100).tolist() + [False]:
        if inked:
            run += 1
        elif run:
            heights.append(run)
            run = 0
    return heights


def test_report_shows_the_sheet_with_legible_captions_and_legend(fixture_run, tmp_path):
    import cv2

    _, run_dir = fixture_run
    result = CliRunner().invoke(main, ["show", "--run", str(run_dir), "--worst", "2", "--out", str(tmp_path / "show")])
    assert result.exit_code == 0, result.output
    sheet = cv2.imread(str(tmp_path / "show" / "overlays.png"))
    shown = 1100 / sheet.shape[1]  # report.html's column is 1,100 px wide at most
    column = sheet[:, 8:8 + 1000]  # the first picture's column
    bar = len(column)  # the caption bar: the rows below the picture's image, which is dark
    while np.median(column[bar - 1]) > 60:
        bar -= 1
    lines = _ink_lines(column[bar:])
    # frame, then the scores; a line of capitals and digits 10 px or more high as shown (7.6 px before)
    assert len(lines) == 2 and min(lines) * shown >= 10, lines
    image_top = 0  # the legend: the rows above the first dark row of the picture's image
    while np.median(column[image_top]) > 60:
        image_top += 1
    assert image_top * shown >= 5 * 20, image_top  # five legend lines, 20 px or more apart as shown


def test_no_caption_runs_past_its_pictures_edge(fixture_run, tmp_path):
    # OpenCV's text width does not scale in proportion: the three methods' scores, shrunk by
    # the ratio alone, ran to the last pixel column and were cut off ("... w/o PFT: L 0.00 R 0.5").
    import cv2

    _, run_dir = fixture_run
    result = CliRunner().invoke(main, ["show", "--run", str(run_dir), "--worst", "4", "--out", str(tmp_path / "show")])
    assert result.exit_code == 0, result.output
    for path in sorted((tmp_path / "show" / "overlays").glob("*.png")):
        picture = cv2.imread(str(path))
        bar = len(picture)  # the caption bar: the rows below the picture's image, which is dark
        while np.median(picture[bar - 1]) > 60:
            bar -= 1
        inked = np.flatnonzero((picture[bar:].min(axis=2) < 100).any(axis=0))
        assert len(inked) and inked.max() <= picture.shape[1] - 8, (path.name, inked.max())


@pytest.mark.parametrize("transparent", [False, True])
def test_a_png_holds_the_pixels_savefig_draws(tmp_path, transparent):
    # write_png encodes the canvas itself (RGB at level 1, 8% of a report sooner); the picture must
    # be savefig's, pixel for pixel, at its dpi, with no text chunk, and keep alpha where there is any.
    import io

    import matplotlib.pyplot as plt
    from PIL import Image

    from roneld_eval.report.figure_files import write_png

    figure, axes = plt.subplots(figsize=(3, 2), dpi=120)
    axes.plot([0, 1, 2], [0.3, 0.9, 0.4], marker="o", label="RONELD")
    axes.set_title("accuracy")
    axes.legend()
    if transparent:
        figure.patch.set_alpha(0.0)
    expected = io.BytesIO()
    figure.savefig(expected, format="png", metadata={"Software": None})
    write_png(figure, tmp_path / "f.png")
    plt.close(figure)
    written, drawn = Image.open(tmp_path / "f.png"), Image.open(expected)
    assert written.mode == ("RGBA" if transparent else "RGB")
    assert np.array_equal(np.asarray(written.convert("RGBA")), np.asarray(drawn.convert("RGBA")))
    assert written.size == drawn.size == (360, 240)
    assert round(written.info["dpi"][0]) == 120 and set(written.info) == {"dpi"}
