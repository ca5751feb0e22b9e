"""VIL-100 predictions as instance masks: one PNG per frame in which every grey value is a lane,
as MMA-Net writes them (libs/utils/utility.py: indexed PNGs with the dataset's palette), turned
into lanes exactly as its evaluation/generate_iou_pred_txt.py does (yujun0-0/MMA-Net 8f95908):

- the PNG is read as skimage's `imread(path, as_gray=True)` reads it: an 8-bit grey PNG as its
  values; a palette or RGB PNG as colours, each colour's grey 0.2125 R + 0.7154 G + 0.0721 B of
  its [0, 1] channels (imageio converts a palette to RGB first); every grey value above 0 is a
  lane, lanes in increasing grey order (`np.unique`), colours of one grey one lane;
- per lane, y = height - row - 1 and x = column + 1 of its pixels, and x = p0 y^2 + p1 y + p2
  fitted by `np.polyfit(y, x, 2)` (also what evaluate_acc.py fits: `InstanceMask.fits`);
- sampled at y = min, min + 3, ... below max; a lane of fewer than two samples is not written; a
  sample is kept when 0 <= x <= width and written as `'%d %d ' % (x, height - y)` (x truncated),
  so a lane whose samples all fall outside is a blank line (a lane of no points to the
  evaluator). Where np.polyfit raises (a lane all in the bottom row), the scripts stop; here such
  a lane has no fit: it writes nothing (it has no samples) and matches no point in evaluate_acc.

Only what that reading defines exactly is accepted: 8-bit grey, palette without transparency,
RGB, or RGBA with every pixel opaque.
"""

from __future__ import annotations

import os
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...errors import InputError
from ...image_header import image_file_size
from ...lanes_io import parse_lines_txt
from ...limits import LANES
from ...model import Lane

Y_STEP = 3  # generate_iou_pred_txt.py: range(min(y), max(y), 3)
GREY_WEIGHTS = (0.2125, 0.7154, 0.0721)  # skimage.color.rgb2gray
MAX_SIDE = 16384  # VIL-100's largest frame is 1920 px wide
MAX_PIXELS = 1 << 26  # 67 M pixels: 35 times VIL-100's largest frame, below Pillow's bomb limit


@dataclass(frozen=True)
class InstanceLane:
    """One grey value's pixels as the script sees them, and its degree-2 fit."""

    ys: np.ndarray  # height - row - 1
    xs: np.ndarray  # column + 1
    # p0, p1, p2 of x = p0 y^2 + p1 y + p2; None where np.polyfit raises (every pixel in the bottom
    # row, y = 0: "SVD did not converge", where both scripts stop)
    fit: tuple[float, float, float] | None


def _grey_image(path: Path) -> np.ndarray:
    """The mask as skimage's imread(as_gray=True) gives it: uint8 for a grey PNG, float64 greys
    for colours; refused (InputError) when it is not a PNG that reading defines."""
    from PIL import Image, UnidentifiedImageError

    width, height = image_file_size(path)
    if not (0 < width <= MAX_SIDE and 0 < height <= MAX_SIDE and width * height <= MAX_PIXELS):
        raise InputError(path, f"a {width}x{height} mask: an instance mask is at most {MAX_SIDE} px a side and "
                               f"{MAX_PIXELS:,} pixels")
    fast = _plain_pixels(path, width, height)
    if fast is not None:
        return fast
    try:
        with Image.open(path) as opened:
            if opened.format != "PNG":  # read all the same by the script: a JPEG's artefacts become lanes
                raise InputError(path, f"a {opened.format} image, not a PNG: an instance mask must be lossless")
            mode, transparent = opened.mode, "transparency" in opened.info
            if mode not in ("L", "RGB", "RGBA") and not (mode == "P" and not transparent):
                raise InputError(path, f"a PNG of mode {mode}{' with transparency' if transparent else ''}: an "
                                       "instance mask is 8-bit grey, or palette or RGB colours (MMA-Net's indexed PNG)")
            # a palette as imageio hands it to skimage: its colours
            pixels = np.asarray(opened.convert("RGB") if mode == "P" else opened)
    except (UnidentifiedImageError, Image.DecompressionBombError, OSError, SyntaxError, ValueError) as error:
        raise InputError(path, f"not a readable PNG: {error}") from None
    if mode == "RGBA":
        # skimage blends RGBA over white (rgba2rgb): exact only where every pixel is opaque
        if not (pixels[..., 3] == 255).all():
            raise InputError(path, "an RGBA mask with transparent pixels: an instance mask is 8-bit grey, or opaque "
                                   "palette or RGB colours (MMA-Net's indexed PNG)")
        pixels = pixels[..., :3]
        mode = "RGB"
    if mode == "L":
        return pixels
    return colour_greys(pixels)


def _plain_pixels(path: Path, width: int, height: int) -> np.ndarray | None:
    """What _grey_image gives for the masks OpenCV writes in grey and Pillow writes as a palette
    (MMA-Net's), decoded here about 8 times faster than by Pillow; None for any other PNG, or one
    larger than such a mask can be, or unreadable: Pillow's to read (or refuse) as before."""
    from ...maps.scnn_png import check_png, plain_png_samples

    most = height * (width + 1) + (1 << 20)  # past 8 bits a pixel, stored
    try:
        with open(path, "rb") as handle:
            data = handle.read(most + 1)
        if len(data) > most:
            return None
        check_png(data, path)
    except (OSError, InputError):
        return None
    decoded = plain_png_samples(data)
    if decoded is None or decoded[0].shape != (height, width):
        return None
    samples, palette = decoded
    if palette is None:
        return samples
    # The palette as Pillow's convert("RGB") gives it, each pixel's colour packed through its
    # index: a gather of the (H, W, 3) colours took 15-20 ms a full-HD mask.
    return _code_greys(_packed(palette)[samples])


def colour_greys(pixels: np.ndarray) -> np.ndarray:
    """An (H, W, 3) uint8 image's greys as rgb2gray computes them: img_as_float64 (x * (1 / 255)),
    then rgb @ coeffs, here on the distinct colours only: the array np.unique(axis=0) gives (black
    first where there is black, then the lit pixels' colours in R, G, B order). OpenBLAS gives a
    row of such a product by the array's size and alignment, so a grey may differ from rgb2gray's
    on the whole image in its last bit; each colour still has one grey, in the same order, which is
    all that makes the lanes. The colours are found among the lit pixels alone, packed in 24 bits:
    np.unique over the rows of every pixel took 3 s a full-HD mask (MMA-Net writes palette PNGs)."""
    return _code_greys(_packed(pixels))


def _packed(colours: np.ndarray) -> np.ndarray:
    """(..., 3) uint8 colours as uint32 0xRRGGBB."""
    return (colours[..., 0].astype(np.uint32) << 16) | (colours[..., 1].astype(np.uint32) << 8) | colours[..., 2]


def _code_greys(codes: np.ndarray) -> np.ndarray:
    """colour_greys of the colours packed as 0xRRGGBB (_packed)."""
    lit = codes != 0
    lit_codes, inverse = np.unique(codes[lit], return_inverse=True)
    colours = np.stack([lit_codes >> 16, (lit_codes >> 8) & 255, lit_codes & 255], axis=1).astype(np.uint8)
    black = int(lit_codes.size < codes.size)  # any unlit pixel: black, the first of the sorted colours
    if black:
        colours = np.concatenate([np.zeros((1, 3), np.uint8), colours])
    greys = np.multiply(colours, 1.0 / 255, dtype=np.float64) @ np.array(GREY_WEIGHTS, dtype=np.float64)
    grey = np.zeros(codes.shape, np.float64)  # black's grey: 0
    grey[lit] = greys[inverse.reshape(-1) + black]
    return grey


def lit_pixels(grey: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(rows, columns) of the pixels above 0, in row-major order, as np.nonzero gives them.
    OpenCV's findNonZero walks the rows in the same order 15 times faster than np.nonzero on a
    full-HD mask of a few lanes (0.1 against 1.7 ms), a tenth of reading a VIL-100 mask."""
    import cv2

    lit = grey if grey.dtype == np.uint8 else (grey > 0).view(np.uint8)
    found = cv2.findNonZero(lit)  # (N, 1, 2) int32 of (x, y); None where no pixel is lit
    if found is None:
        empty = np.zeros(0, np.intp)
        return empty, empty
    points = found.reshape(-1, 2).astype(np.intp)
    return points[:, 1], points[:, 0]


def quadratic_fit(ys: np.ndarray, xs: np.ndarray) -> np.ndarray:
    """np.polyfit(ys, xs, 2) to the last bit: its very steps on the very same arrays, but for its
    Vandermonde matrix, whose columns y * y, y and 1 are written here instead of accumulated along
    strided rows (a quarter of the fit's time on a full-HD mask's lane of ~20,000 pixels), for
    integer or float64 rows and columns (what instance_lanes passes). Its RankWarning is not given;
    LinAlgError is raised as it raises it, and TypeError for no pixel."""
    x = np.asarray(ys) + 0.0
    y = np.asarray(xs) + 0.0
    if x.size == 0:
        raise TypeError("expected non-empty vector for x")  # as np.polyfit (an empty running sum has no last)
    lhs = np.empty((x.size, 3), np.float64)
    squares = x * x
    lhs[:, 0] = squares
    lhs[:, 1] = x
    lhs[:, 2] = 1.0
    # polyfit's (lhs * lhs).sum(axis=0) adds each column's terms in row order, as a running sum
    # does (not pairwise, as a sum along a contiguous array would): the same doubles, in half the
    # time of the strided reduction.
    scale = np.sqrt(np.array([np.add.accumulate(squares * squares)[-1], np.add.accumulate(squares)[-1],
                              float(x.size)]))
    lhs /= scale
    coefficients = np.linalg.lstsq(lhs, y, x.size * np.finfo(np.float64).eps)[0]
    return (coefficients.T / scale).T


def instance_lanes(path: Path) -> tuple[list[InstanceLane], int, int]:
    """(lanes in grey order, width, height) of one mask."""
    grey = _grey_image(path)
    height, width = grey.shape
    rows, columns = lit_pixels(grey)
    values = grey[rows, columns]
    # Grouped by value with a stable sort, so that each lane's pixels come in the order the
    # script's np.where gives them.
    order = np.argsort(values, kind="stable")
    grouped = values[order]
    starts: list[int] = []
    if grouped.size:
        starts = np.flatnonzero(np.concatenate([[True], grouped[1:] != grouped[:-1]])).tolist()
    if len(starts) > LANES.count:  # each grey is fitted, and drawn as a lane: bounded before any fit
        raise InputError(path, LANES.problem(len(starts), "grey values"))
    ends = starts[1:] + [grouped.size]
    lanes = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # np.polyfit's RankWarning on a lane of one or two rows
        for start, end in zip(starts, ends):
            members = order[start:end]
            ys, xs = height - rows[members] - 1, columns[members] + 1
            try:
                if not ys.any():  # all in the bottom row: polyfit's scaling divides by 0 (LAPACK says so on stdout)
                    raise np.linalg.LinAlgError("SVD did not converge")
                fit = quadratic_fit(ys, xs).tolist()  # float64 of either: the same as the script's lists
            except np.linalg.LinAlgError:
                lanes.append(InstanceLane(ys, xs, None))
                continue
            lanes.append(InstanceLane(ys, xs, (fit[0], fit[1], fit[2])))
    return lanes, width, height


def lines_text(lanes: list[InstanceLane], width: int, height: int) -> str:
    """The .lines.txt generate_iou_pred_txt.py writes for these lanes."""
    out = []
    for lane in lanes:
        txty = list(range(int(lane.ys.min()), int(lane.ys.max()), Y_STEP))
        if lane.fit is None:  # one row (y = 0): no sample either
            continue
        p0, p1, p2 = lane.fit
        samples = np.array(txty)
        txtx = (p0 * samples * samples + p1 * samples + p2).tolist()
        if len(txtx) >= 2:
            out.append("".join("%d %d " % (x, height - y) for x, y in zip(txtx, txty) if 0 <= x <= width) + "\n")
    return "".join(out)


@dataclass(frozen=True)
class InstanceMask:
    """A frame's mask as both MMA-Net scripts see it: the lanes the evaluator reads from the text
    generate_iou_pred_txt.py writes, and the fits evaluate_acc.py uses (with the mask's height)."""

    lanes: tuple[Lane, ...]
    fits: tuple[tuple[float, float, float] | None, ...]
    height: int | None  # None: no mask
    width: int | None = None


def read_instance_png(path: Path) -> InstanceMask:
    """A frame's mask; no lanes when the file is absent (as a missing .lines.txt)."""
    if not os.path.lexists(path):
        return InstanceMask((), (), None)
    lanes, width, height = instance_lanes(path)
    return InstanceMask(parse_lines_txt(lines_text(lanes, width, height), path),
                        tuple(lane.fit for lane in lanes), height, width)
