"""Dataset readers on hand-written trees and on the real CULane and TuSimple files."""

import gzip
import shutil

import numpy as np
import pytest
from click.testing import CliRunner
from conftest import write_culane_tree
from hypothesis import given, settings
from hypothesis import strategies as st

from roneld_eval.cli import main
from roneld_eval.api import read_dataset
from roneld_eval.benchmarks.culane.reader import read_culane
from roneld_eval.benchmarks.tusimple.reader import read_tusimple
from roneld_eval.errors import InputError
from roneld_eval.json_fields import is_finite_number
from roneld_eval.benchmarks.tusimple.lane_format import tusimple_xs
from roneld_eval.lanes_io import _all_numbers, parse_lines_txt


def test_culane_clips_frames_and_lanes(tmp_path):
    root = write_culane_tree(tmp_path, {
        "driver_1/a.MP4/00060.jpg": "1 590 2 580 \n3 590 4 580",
        "driver_1/a.MP4/00000.jpg": "",
        "driver_2/b.MP4/00030.jpg": None,
        "driver_1/a.MP4/00030.jpg": "10.5 300.25 11 290\n",
    }, categories={"normal": ["driver_1/a.MP4/00000.jpg"], "curve": ["driver_2/b.MP4/00030.jpg"]})
    dataset = read_culane(root)
    assert [clip.clip_id for clip in dataset.clips] == ["driver_1/a.MP4", "driver_2/b.MP4"]
    first = dataset.clips[0]
    assert [f.relpath for f in first.frames] == [
        "driver_1/a.MP4/00000.jpg", "driver_1/a.MP4/00030.jpg", "driver_1/a.MP4/00060.jpg"]
    assert first.frames[0].lanes == ()
    assert first.frames[1].lanes[0].points.tolist() == [[10.5, 300.25], [11.0, 290.0]]
    assert len(first.frames[2].lanes) == 2  # last line without a newline
    assert dataset.clips[1].frames[0].lanes == ()  # no file: no lanes
    assert dataset.categories == {"normal": frozenset({"driver_1/a.MP4/00000.jpg"}),
                                  "curve": frozenset({"driver_2/b.MP4/00030.jpg"})}
    assert (dataset.image_width, dataset.image_height) == (1640, 590)
    assert len(read_culane(root, limit=1).clips) == 1


def test_culane_lines_follow_the_official_reader():
    # Every line is a lane, an empty one too; a final newline does not start another.
    lanes = parse_lines_txt("1 2 3 4 \n\n5 6 7 8\n", "x")
    assert [len(lane) for lane in lanes] == [2, 0, 2]
    assert parse_lines_txt("", "x") == ()
    assert len(parse_lines_txt("\n", "x")) == 1
    assert parse_lines_txt("-38.0034 440 8.8 430\r\n", "x")[0].points[0].tolist() == [-38.0034, 440]


@pytest.mark.parametrize("text, problem", [
    ("1 2 3\n", "line 1: odd number of values"),
    ("1 2\n3 x\n", "line 2: 'x' is not a number"),
    ("1 nan\n", "'nan' is not a number"),
    ("1_000 2\n", "'1_000' is not a number"),
])
def test_bad_lines_name_the_file_and_line(text, problem):
    with pytest.raises(InputError) as caught:
        parse_lines_txt(text, "gt/00000.lines.txt")
    assert str(caught.value).startswith("gt/00000.lines.txt:")
    assert problem.split(": ", 1)[-1] in str(caught.value)


def test_a_folder_without_a_list_is_told_what_a_list_line_is_and_how_to_give_one(tmp_path):
    # the message was "list file not found", naming list/test.txt, and no more
    for name in ("00030.lines.txt", "00000.lines.txt", "00000.jpg"):
        (tmp_path / name).write_text("100 580 200 400\n")
    with pytest.raises(InputError) as caught:
        read_culane(tmp_path)
    said = str(caught.value)
    assert said.startswith(f"{tmp_path / 'list' / 'test.txt'}: list file not found: ")
    assert "(00000.jpg for this folder's 00000.lines.txt)" in said and "give it with --list FILE" in said
    (tmp_path / "deeper").mkdir()
    with pytest.raises(InputError, match=r"\(e\.g\. driver_37_30frame/05181432_0203\.MP4/00000\.jpg\).* --list FILE"):
        read_culane(tmp_path / "deeper")


def test_run_on_the_real_list_less_clip_says_how_to_list_it(real_clip, tmp_path):
    result = CliRunner().invoke(main, ["run", "--dataset", "culane", "--data-root", str(real_clip), "--maps-root",
                                       str(real_clip), "--maps-format", "scnn-png", "--out", str(tmp_path / "o")])
    assert result.exit_code == 2 and result.output.count("\n") == 1, result.output
    assert "00000.jpg for this folder's 00000.lines.txt" in result.output and "--list FILE" in result.output
    listed = tmp_path / "list.txt"  # and the list it describes is one `run` reads
    labels = sorted(real_clip.glob("*.lines.txt"))
    listed.write_text("".join(f"{path.name[:-len('.lines.txt')]}.jpg\n" for path in labels))
    result = CliRunner().invoke(main, ["run", "--dataset", "culane", "--data-root", str(real_clip), "--maps-root",
                                       str(real_clip), "--maps-format", "scnn-png", "--list", str(listed), "--dry-run"])
    assert result.exit_code == 0 and "1 clip, 90 frames (90 labelled, scored)" in result.output, result.output


def test_culane_bad_trees(tmp_path):
    with pytest.raises(InputError, match="dataset root not found"):
        read_culane(tmp_path / "nowhere")
    with pytest.raises(InputError, match="list file not found"):
        read_culane(tmp_path)
    write_culane_tree(tmp_path, {}, list_text="\n \n")
    with pytest.raises(InputError, match="names no images"):
        read_culane(tmp_path)
    write_culane_tree(tmp_path, {}, list_text="/a/b.MP4/00000.jpg\n/../etc/passwd\n")
    with pytest.raises(InputError, match=r"test.txt:2: .* outside the dataset root"):
        read_culane(tmp_path)
    write_culane_tree(tmp_path, {}, list_text="/a/b.MP4/00000.jpg\na/b.MP4/00000.jpg \n")
    with pytest.raises(InputError, match="listed twice"):
        read_culane(tmp_path)


def test_tusimple_clips(tmp_path):
    rows = list(range(160, 720, 10))
    lane = [-2] * 10 + list(range(600, 600 + 46))
    (tmp_path / "test_label.json").write_text(
        '{"lanes": [%s], "h_samples": %s, "raw_file": "clips/0530/x_0/20.jpg"}\n' % (lane, rows)
        + '{"lanes": [], "h_samples": %s, "raw_file": "clips/0601/y/20.jpg"}\n' % rows
    )
    dataset = read_tusimple(tmp_path)
    assert [c.clip_id for c in dataset.clips] == ["clips/0530/x_0", "clips/0601/y"]
    clip = dataset.clips[0]
    assert [f.relpath for f in clip.frames][:2] == ["clips/0530/x_0/1.jpg", "clips/0530/x_0/2.jpg"]
    assert len(clip.frames) == 20 and [f.labelled for f in clip.frames].count(True) == 1
    labelled = clip.frames[-1]
    assert labelled.h_samples == tuple(rows)
    assert len(labelled.lanes[0]) == 46 and labelled.lanes[0].points[0].tolist() == [600, 260]
    assert tusimple_xs(labelled.lanes[0], rows) == [float(v) for v in lane]
    assert (dataset.image_width, dataset.image_height) == (1280, 720)


@pytest.mark.parametrize("line, problem", [
    ("not json", "not valid JSON"),
    ('{"lanes": [], "raw_file": "a/20.jpg"}', "missing key 'h_samples'"),
    ('{"lanes": [[1, 2]], "h_samples": [1], "raw_file": "a/20.jpg"}', "lane 0 has 2 values but h_samples has 1"),
    ('{"lanes": [["a"]], "h_samples": [1], "raw_file": "a/20.jpg"}', "not a finite number"),
    # a sum of the values is finite, each value is not: each is checked
    ('{"lanes": [[1e400, -1e400]], "h_samples": [1, 2], "raw_file": "a/20.jpg"}', "lane 0 holds a value that is not"),
    ('{"lanes": [[1' + "0" * 400 + ', -1' + "0" * 400 + ']], "h_samples": [1, 2], "raw_file": "a/20.jpg"}',
     "lane 0 holds a value that is not"),
    ('{"lanes": [[1, 2]], "h_samples": [true, 2], "raw_file": "a/20.jpg"}', "h_samples must be a list of numbers"),
    ('[1, 2]', "JSON object"),
])
def test_tusimple_bad_labels(tmp_path, line, problem):
    (tmp_path / "test_label.json").write_text('{"lanes": [], "h_samples": [], "raw_file": "b/20.jpg"}\n' + line + "\n")
    with pytest.raises(InputError, match=problem) as caught:
        read_tusimple(tmp_path)
    assert ":2:" in str(caught.value)


_JSON_VALUES = st.one_of(st.integers(-(10**320), 10**320), st.floats(), st.booleans(), st.none(), st.text(max_size=2),
                         st.sampled_from([1.7e308, -1.7e308, 10**308 * 2, 2**1024 - 1, float("nan")]))


@settings(max_examples=300, deadline=None, derandomize=True)
@given(st.lists(_JSON_VALUES, max_size=6))
def test_a_list_is_all_numbers_exactly_when_each_value_is_one(values):
    # The sum taken for speed must not let through what the check of each value refuses.
    assert _all_numbers(values) == all(is_finite_number(value) for value in values)


def test_real_culane_lists(shared_data, tmp_path):
    lists = shared_data / "culane-lists"
    (tmp_path / "list").mkdir()
    shutil.copy(lists / "test.txt", tmp_path / "list" / "test.txt")
    shutil.copytree(lists / "test_split", tmp_path / "list" / "test_split")
    dataset = read_culane(tmp_path)
    assert dataset.n_frames == 34680 and len(dataset.clips) == 419
    sizes = {name: len(members) for name, members in dataset.categories.items()}
    assert sizes == dict(normal=9621, crowd=8113, hlight=486, shadow=930, noline=4067, arrow=890,
                         curve=422, cross=3122, night=7029)
    everything = set().union(*dataset.categories.values())
    assert everything == {f.relpath for c in dataset.clips for f in c.frames}
    numbers = [int(f.relpath[-9:-4]) for f in dataset.clips[0].frames]
    assert numbers == sorted(numbers)


def test_real_culane_raw_labels(shared_data):
    from roneld_eval.lanes_io import read_lines_txt

    files = sorted((shared_data / "culane-raw-labels").glob("*.lines.txt"))
    assert len(files) == 47
    for path in files:
        lanes = read_lines_txt(path)
        assert 2 <= len(lanes) <= 4
        assert all(len(lane) >= 2 for lane in lanes)
    first = read_lines_txt(shared_data / "culane-raw-labels" / "00000.lines.txt")
    assert first[0].points[0].tolist() == [-38.0034, 440.0]


def test_real_tusimple_labels(shared_data, tmp_path):
    with gzip.open(shared_data / "tusimple" / "test_label.json.gz", "rb") as handle:
        (tmp_path / "test_label.json").write_bytes(handle.read())
    dataset = read_dataset("tusimple", tmp_path)
    assert len(dataset.clips) == 2782 and dataset.n_labelled == 2782 and dataset.n_frames == 2782 * 20
    lanes = [len(f.lanes) for c in dataset.clips for f in c.labelled_frames]
    assert max(lanes) == 5 and min(lanes) >= 1
    assert all(np.all(lane.points[:, 0] >= 0)
               for c in dataset.clips[:50] for f in c.labelled_frames for lane in f.lanes)
