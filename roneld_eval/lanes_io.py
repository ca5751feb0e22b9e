"""Lanes in the benchmarks' own file formats: CULane `.lines.txt` and TuSimple JSON lines.

Parsing follows the official tools where they are strict and fails loudly where they are
silent (the C++ CULane reader stops at the first non-number; we name the file and line).
Writers produce files the official tools read back to exactly the lanes we scored. Every text
input (config TOML aside: config.py reads it by the same rules) goes through `read_text`:
regular files only (a FIFO or a device is refused before anything is read), UTF-8 whatever
the locale, a byte-order mark dropped, and every OSError an InputError naming the file.
"""

from __future__ import annotations

import math
import os
import re
import stat
from pathlib import Path
from typing import Any, Iterable, Literal, overload

import numpy as np

from .errors import InputError
from .json_fields import RepeatedKey, is_finite_number, loads, shown
from .limits import LANES, TEXT, SizeLimit
from .model import Lane

# A decimal number as C++'s `istream >> double` reads it (no Python-only spellings such
# as '1_000', 'nan' or 'inf').
_NUMBER = re.compile(r"[+-]?([0-9]+\.?[0-9]*|\.[0-9]+)([eE][+-]?[0-9]+)?\Z")
# Characters of decimal numbers and whitespace. A file made only of them is parsed with
# float() at C speed; any other file (or a float() failure) goes token by token through
# _NUMBER, which names the bad line. float() alone would accept 'nan', 'inf' and '1_000'.
_NOT_NUMERIC = str.maketrans("", "", "0123456789.eE+- \t\r\n")


_OPEN_FLAGS = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0) | getattr(os, "O_BINARY", 0)


def _not_regular(mode: int) -> str | None:
    """What a file that is not a regular file is, in words (None for a regular file)."""
    if stat.S_ISREG(mode):
        return None
    if stat.S_ISDIR(mode):
        return "is a folder, not a file"
    if stat.S_ISFIFO(mode):
        return "is a FIFO (named pipe), not a regular file"
    if stat.S_ISSOCK(mode):
        return "is a socket, not a regular file"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "is a device, not a regular file"
    return "is not a regular file"


def _os_problem(error: OSError) -> str:
    if isinstance(error, (FileNotFoundError, NotADirectoryError)):
        return "file not found"
    return f"cannot read: {error.strerror or error}"


def check_folder(path: Path, missing: str, hint: str = "") -> None:
    """Refuse, naming it, a `path` that is not a folder: `missing` where nothing is there, else what
    is there instead (a file given for a folder was said "not found"); `hint` said after either."""
    if os.path.isdir(path):
        return
    if not os.path.lexists(path):
        problem = missing
    else:
        problem = "is a file, not a folder" if os.path.isfile(path) else "is not a folder"
    raise InputError(path, problem + hint)


def check_regular_file(path: Path, missing: str = "file not found", limit: SizeLimit | None = None) -> None:
    """Refuse, naming the file, anything but a readable regular file (before a library opens it),
    and one larger than `limit`.

    A FIFO or a device is refused without being opened, so it cannot hang a run.
    """
    try:
        info = os.stat(path)
    except (FileNotFoundError, NotADirectoryError):
        raise InputError(path, missing) from None
    except OSError as error:
        raise InputError(path, _os_problem(error)) from None
    except ValueError:  # a NUL character in the name
        raise InputError(path, "not a usable file name") from None
    problem = _not_regular(info.st_mode)
    if problem is None and limit is not None and info.st_size > limit.bytes:
        problem = limit.problem(info.st_size)
    if problem is not None:
        raise InputError(path, problem)


@overload
def read_bytes(path: Path, missing_ok: Literal[False] = False, limit: SizeLimit = TEXT) -> bytes: ...


@overload
def read_bytes(path: Path, missing_ok: bool, limit: SizeLimit = TEXT) -> bytes | None: ...


def read_bytes(path: Path, missing_ok: bool = False, limit: SizeLimit = TEXT) -> bytes | None:
    """A regular file's bytes, or an InputError naming it (None for a missing file if `missing_ok`).

    Opened without blocking and checked before reading, so a FIFO or a device given as an
    input is one clear error, never a hang, and a file larger than `limit` is refused unread.
    Every OSError becomes an InputError.
    """
    try:
        descriptor = os.open(path, _OPEN_FLAGS)
    except (FileNotFoundError, NotADirectoryError) as error:
        if os.path.islink(path):  # not a missing file (no lanes) but a broken link: a mistake to name
            raise InputError(path, "a link to nothing (its target does not exist)") from None
        if missing_ok:
            return None
        raise InputError(path, _os_problem(error)) from None
    except IsADirectoryError:
        raise InputError(path, "is a folder, not a file") from None
    except OSError as error:
        raise InputError(path, _os_problem(error)) from None
    except ValueError:  # a NUL character in the name
        raise InputError(path, "not a usable file name") from None
    most = limit.bytes
    try:
        # Checked before fdopen, which refuses a folder with an error naming the descriptor.
        info = os.fstat(descriptor)
        problem = _not_regular(info.st_mode)
        if problem is None and info.st_size > most:
            problem = limit.problem(info.st_size)
    except OSError as error:
        os.close(descriptor)
        raise InputError(path, _os_problem(error)) from None
    if problem is not None:
        os.close(descriptor)
        raise InputError(path, problem)
    with os.fdopen(descriptor, "rb") as handle:
        try:
            data = read_at_most(handle, most, info.st_size)
        except OSError as error:
            raise InputError(path, _os_problem(error)) from None
    if len(data) > most:
        raise InputError(path, limit.problem(len(data)))
    return data


def read_at_most(handle, most: int, size: int) -> bytes:
    """Up to `most` + 1 bytes of a file whose size was `size`: read(n) allocates n bytes at once,
    so the bound alone (which a user may raise past the machine's memory) is never asked for."""
    data = handle.read(min(size, most) + 1)
    if len(data) <= size or len(data) > most:
        return data
    parts = [data]  # the file grew since its size was looked at
    total = len(data)
    while total <= most:
        part = handle.read(min(1 << 20, most + 1 - total))
        if not part:
            break
        parts.append(part)
        total += len(part)
    return b"".join(parts)


def decode_text(data: bytes, path) -> str:
    """UTF-8 text whatever the locale, a leading byte-order mark dropped (as every text input)."""
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as error:
        raise InputError(
            path, f"not a UTF-8 text file (byte 0x{data[error.start]:02x} at offset {error.start})"
        ) from None
    return text[1:] if text.startswith("\ufeff") else text


def parse_json(data: bytes | str, path, not_json: str, kind: str) -> Any:
    """A JSON file's value, or an InputError naming it: '<not_json>: <error>' for bytes that are
    not UTF-8 JSON, '<kind>: nested too deeply' where Python's parser runs out of stack (an
    untrusted file may nest a million brackets), the key where an object names one twice."""
    try:
        return loads(data.decode("utf-8") if isinstance(data, bytes) else data)
    except RepeatedKey as error:
        raise InputError(path, str(error)) from None
    except (UnicodeDecodeError, ValueError) as error:
        raise InputError(path, f"{not_json}: {error}") from None
    except RecursionError:
        raise InputError(path, f"{kind}: nested too deeply") from None


def read_text(path: Path, limit: SizeLimit = TEXT) -> str:
    """A text file's content (UTF-8, BOM dropped), or an InputError saying why it cannot be read."""
    return decode_text(read_bytes(path, limit=limit), path)


def split_lines(text: str) -> list[str]:
    """Lines as C++ getline yields them: a final newline does not start another line."""
    lines = text.split("\n")
    if lines and lines[-1] == "":
        lines.pop()
    return lines


def parse_number(token: str, path, line: int) -> float:
    if not _NUMBER.match(token):
        raise InputError(path, f"{shown(token)} is not a number", line=line)
    return float(token)


def parse_lines_txt(text: str, path) -> tuple[Lane, ...]:
    """CULane `.lines.txt`: one lane per line, `x y x y ...` in image pixels.

    Every line is a lane, an empty one too (the official evaluator counts it, with IoU 0).
    """
    lanes = []
    clean = not text.translate(_NOT_NUMERIC)
    lines = split_lines(text)
    if len(lines) > LANES.count:
        raise InputError(path, LANES.problem(len(lines)))
    for number, line in enumerate(lines, start=1):
        tokens = line.split()
        try:
            if not clean:
                raise ValueError
            values = list(map(float, tokens))
        except ValueError:
            values = [parse_number(token, path, number) for token in tokens]
        if len(values) % 2:
            raise InputError(
                path, f"odd number of values ({len(values)}): every point needs an x and a y", line=number
            )
        lanes.append(Lane(np.array(values, np.float64).reshape(-1, 2)))
    return tuple(lanes)


# The farthest a predicted coordinate may lie from the origin: beyond float32's integers the
# C++ evaluator's spline and cvRound saturate in ways not emulated (off by a few pixels at
# +-2^31), and drawing such a lane overflows; no detector's lane reaches 16.7 million pixels.
MAX_PREDICTED_COORDINATE = float(1 << 24)
FAR_FROM_ORIGIN = "lies more than 2^24 px (16,777,216) from the image origin"


def numpy_array_of(values: Any) -> np.ndarray:
    """JSON values (a list, of equally long lists) as NumPy makes an array of them, as the Python
    evaluators read them (true and false are 1 and 0 there); an empty object array where NumPy
    cannot make one (ragged lists, integers past int64 and a float)."""
    try:
        return np.array(values)
    except (ValueError, TypeError, OverflowError):
        return np.array([], dtype=object)


def finite_numbers(array: np.ndarray) -> bool:
    """Whether numpy_array_of gave finite numbers: not text, null or a ragged list, not NaN or an
    infinity (booleans count, as numbers of 0 and 1)."""
    return array.dtype.kind in "biuf" and (array.dtype.kind != "f" or bool(np.isfinite(array).all()))


def check_coordinates(lanes, path, line: int | None = None) -> None:
    """Refuse predicted lanes with a coordinate no lane can have (a unit mistake, an overflow):
    named by the lane's line, or for lanes that share a `line` (TuSimple) by their index."""
    for index, lane in enumerate(lanes):
        points = lane.points
        with np.errstate(invalid="ignore"):
            bad = np.abs(points) > MAX_PREDICTED_COORDINATE
        if bad.any():
            x, y = points[int(np.argmax(bad.any(axis=1)))]
            problem = f"point ({x:.10g}, {y:.10g}) {FAR_FROM_ORIGIN}: not a lane coordinate"
            if line is None:
                raise InputError(path, problem, line=index + 1)
            raise InputError(path, f"lane {index}: {problem}", line=line)


def read_lines_txt(path: Path, missing_ok: bool = True) -> tuple[Lane, ...]:
    """Lanes of one `.lines.txt`; a missing file means no lanes when `missing_ok`."""
    path = Path(path)
    data = read_bytes(path, missing_ok=missing_ok)
    if data is None:
        return ()
    return parse_lines_txt(decode_text(data, path), path)


SCORES_SUFFIX = ".scores.txt"  # beside a frame's .lines.txt: one score a lane line


def scores_path(lines_path: Path) -> Path:
    """The `.scores.txt` beside a `<stem>.lines.txt`."""
    return lines_path.with_name(lines_path.name.removesuffix(".lines.txt") + SCORES_SUFFIX)


def read_scores_beside(lines_path: Path, n_lanes: int) -> tuple[float, ...]:
    """read_lane_scores of the `.scores.txt` beside a `.lines.txt`."""
    return read_lane_scores(scores_path(lines_path), n_lanes)


def read_lane_scores(path: Path, n_lanes: int) -> tuple[float, ...]:
    """The `.scores.txt` beside a `.lines.txt` of `n_lanes` lanes: one score in [0, 1] a lane line
    (1.0 for every lane when the file is missing)."""
    data = read_bytes(path, missing_ok=True)
    if data is None:
        return (1.0,) * n_lanes
    values = []
    for number, line in enumerate(decode_text(data, path).splitlines(), start=1):
        if line.strip():
            values.append(check_score(line.strip(), path, number))
    if len(values) != n_lanes:
        raise InputError(path, f"{len(values)} scores for {n_lanes} lanes: one score per lane line")
    return tuple(values)


def check_score(value, path, line: int | None) -> float:
    """A lane's score: a number in [0, 1], or an InputError naming the file and line."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        number = float("nan")
    if isinstance(value, bool) or not 0.0 <= number <= 1.0:
        raise InputError(path, f"lane score {shown(value)} is not a number in [0, 1]", line=line)
    return number


def format_coordinate(value: float) -> str:
    """Shortest text that reads back to the same float32 (what the C++ evaluator stores)."""
    return np.format_float_positional(np.float32(value), trim="-")


def format_lines_txt(lanes: Iterable[Lane]) -> str:
    """`.lines.txt` text, one lane per line, coordinates as float32 like the C++ reader keeps them."""
    out = []
    for lane in lanes:
        out.append(" ".join(format_coordinate(v) for v in lane.points.ravel()))
    return "".join(line + "\n" for line in out)


def _all_numbers(values: list) -> bool:
    """Whether every value is a finite number (json_fields.is_finite_number). Checked a value at a time, the
    2,782 lines of TuSimple's test labels took 0.12 s on top of their 0.06 s of JSON. A finite
    sum of the magnitudes of ints and floats has no inf, NaN or integer beyond a float's range
    among them, so most lists need no loop in Python."""
    if set(map(type, values)) <= {int, float}:
        try:
            if math.isfinite(sum(map(abs, values))):
                return True
        except OverflowError:  # an integer beyond a float's range: the loop below says which
            pass
    return all(is_finite_number(value) for value in values)


def sample_lane_at_rows(lane: Lane, rows: Iterable[float]) -> list[float]:
    """x of a polyline lane at each row by linear interpolation, -2 outside its rows."""
    rows = np.asarray(list(rows), np.float64)
    if len(lane) < 2:
        return [-2.0] * len(rows)
    points = lane.top_to_bottom().points
    ys, xs = points[:, 1], points[:, 0]
    # Duplicate rows: keep the first point of each so the interpolation is defined.
    keep = np.concatenate([[True], np.diff(ys) > 0])
    ys, xs = ys[keep], xs[keep]
    if len(ys) < 2:
        return [-2.0] * len(rows)
    values = np.interp(rows, ys, xs)
    inside = (rows >= ys[0]) & (rows <= ys[-1]) & (values >= 0)
    return [round(float(v), 3) if ok else -2.0 for v, ok in zip(values, inside)]


def check_inside_image(lanes, path, width: int, height: int) -> None:
    """Refuse points farther outside the image than its own size (labels overshoot a little)."""
    for number, lane in enumerate(lanes, start=1):
        points = lane.points
        if not len(points):
            continue
        xs, ys = points[:, 0], points[:, 1]
        bad = (xs < -width) | (xs > 2 * width) | (ys < -height) | (ys > 2 * height)
        if bad.any():
            x, y = points[np.argmax(bad)]
            raise InputError(path, f"point ({x:g}, {y:g}) lies far outside the {width}x{height} image", line=number)
