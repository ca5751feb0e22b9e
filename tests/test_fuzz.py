"""Readers on random bytes and malformed lines: they parse, or raise InputError, never anything else."""

import json

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from roneld_eval.config import MapsConfig
from roneld_eval.benchmarks.culane.reader import read_list_file
from roneld_eval.errors import InputError
from roneld_eval.benchmarks.tusimple.lane_format import read_tusimple_records
from roneld_eval.lanes_io import parse_lines_txt, read_lines_txt
from roneld_eval.maps import load_maps

FUZZ = settings(max_examples=150, deadline=None, derandomize=True,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])

NUMBERISH = st.sampled_from(["1", "-2.5", "1e3", ".5", "5.", "nan", "inf", "1_0", "x", "--1", "1e", "+", "",
                             " ", "\t", "\r", "\n", "0x10", "٣", "1.2.3", "-", "e5", "1E-2"])


def _ok_or_input_error(function, *args):
    try:
        function(*args)
    except InputError as error:
        assert str(error)
        return False
    return True


@FUZZ
@given(st.lists(NUMBERISH, max_size=40).map(" ".join))
def test_culane_lines_from_number_like_tokens(text):
    if _ok_or_input_error(parse_lines_txt, text, "f.lines.txt"):
        for lane in parse_lines_txt(text, "f.lines.txt"):
            assert np.isfinite(lane.points).all()


@FUZZ
@given(st.binary(max_size=300))
def test_culane_lines_from_random_bytes(tmp_path_factory, data):
    path = tmp_path_factory.mktemp("f") / "x.lines.txt"
    path.write_bytes(data)
    _ok_or_input_error(read_lines_txt, path)


@FUZZ
@given(st.binary(max_size=300))
def test_list_files_from_random_bytes(tmp_path_factory, data):
    path = tmp_path_factory.mktemp("f") / "test.txt"
    path.write_bytes(data)
    _ok_or_input_error(read_list_file, path)


JSON_VALUES = st.recursive(
    st.none() | st.booleans() | st.integers(-5, 2000) | st.floats(allow_nan=False, allow_infinity=False)
    | st.text(max_size=5),
    lambda children: st.lists(children, max_size=4) | st.dictionaries(st.sampled_from(
        ["raw_file", "lanes", "h_samples", "run_time", "x"]), children, max_size=4),
    max_leaves=20,
)


@FUZZ
@given(st.lists(JSON_VALUES.map(json.dumps) | st.text(max_size=30), max_size=5), st.booleans())
def test_tusimple_lines_from_random_json(tmp_path_factory, lines, predictions):
    path = tmp_path_factory.mktemp("f") / "labels.json"
    path.write_text("\n".join(lines))
    _ok_or_input_error(read_tusimple_records, path, predictions)


@FUZZ
@given(st.binary(max_size=400), st.sampled_from(["npy", "npz", "scnn-png"]))
def test_map_files_from_random_bytes(tmp_path_factory, data, fmt):
    folder = tmp_path_factory.mktemp("m")
    if fmt == "scnn-png":
        for k in range(1, 5):
            (folder / f"f_{k}_avg.png").write_bytes(data)
        (folder / "f.exist.txt").write_bytes(data[:20])
    else:
        (folder / f"f.{fmt}").write_bytes(data)
    _ok_or_input_error(load_maps, folder, "f.jpg", MapsConfig(format=fmt))


@FUZZ
@given(st.binary(min_size=0, max_size=64))
def test_npy_with_a_valid_header_and_random_body(tmp_path_factory, body):
    folder = tmp_path_factory.mktemp("m")
    np.save(folder / "f.npy", np.zeros((4, 3, 5), np.uint8))
    data = (folder / "f.npy").read_bytes()
    (folder / "f.npy").write_bytes(data[:128] + body)
    _ok_or_input_error(load_maps, folder, "f.jpg", MapsConfig())
