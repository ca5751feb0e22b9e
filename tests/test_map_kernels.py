"""The map-decoding kernel against a slow, obvious version: unfilter every pixel, compare every
channel. Inputs are mostly zero, like real maps, so that the kernel's skipping of zero words,
pixels straddling two words, and filter bytes inside a row's words are all met."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from roneld_eval.maps._kernels import unfilter_grey, unfilter_stream


def slow_unfilter(stream: np.ndarray, height: int, width: int, samples: int) -> tuple[np.ndarray, bool]:
    """Row by row, pixel by pixel: Sub adds the pixel to its left (mod 256), None keeps it."""
    out = np.zeros((height, width), np.uint8)
    same = True
    stride = 1 + width * samples
    for y in range(height):
        row = stream[y * stride:(y + 1) * stride]
        left = 0
        for x in range(width):
            pixel = [int(v) for v in row[1 + x * samples:1 + (x + 1) * samples]]
            if any(value != pixel[0] for value in pixel[1:3]):
                same = False
            value = (left + pixel[0]) % 256 if row[0] == 1 else pixel[0]
            out[y, x] = value
            left = value
    return out, same


@st.composite
def streams(draw):
    height = draw(st.integers(1, 12))
    width = draw(st.integers(1, 40))
    samples = draw(st.sampled_from([1, 3, 4]))
    seed = draw(st.integers(0, 2**32 - 1))
    density = draw(st.sampled_from([0.0, 0.005, 0.05, 0.5, 1.0]))
    rng = np.random.default_rng(seed)
    grey = np.where(rng.random((height, width)) < density, rng.integers(1, 256, (height, width)), 0)
    pixels = np.repeat(grey[:, :, None], samples, axis=2).astype(np.uint8)
    if samples == 4:
        pixels[:, :, 3] = rng.integers(0, 256, (height, width))  # alpha is not looked at
    if draw(st.booleans()):  # a colour pixel somewhere: the map is not grey
        y, x = int(rng.integers(height)), int(rng.integers(width))
        if samples > 1:
            pixels[y, x, int(rng.integers(1, min(samples, 3)))] ^= np.uint8(rng.integers(1, 256))
    filters = rng.integers(0, 2, height).astype(np.uint8)
    stream = np.concatenate([filters[:, None], pixels.reshape(height, width * samples)], axis=1).reshape(-1)
    return np.ascontiguousarray(stream), height, width, samples


@settings(max_examples=400, deadline=None)
@given(streams())
def test_unfilter_grey_matches_the_slow_version(case):
    stream, height, width, samples = case
    words = stream[:stream.size // 8 * 8].view(np.uint64)
    image, same = unfilter_grey(stream, words, height, width, samples)
    expected, expected_same = slow_unfilter(stream, height, width, samples)
    assert same == expected_same
    np.testing.assert_array_equal(image, expected)


def test_a_filter_byte_in_a_zero_row_changes_nothing():
    # Every row Sub and every pixel zero: the only set bytes are the filter bytes, which share
    # words with the pixels around them.
    height, width = 9, 13
    stream = np.zeros(height * (1 + width * 3), np.uint8)
    stream[::1 + width * 3] = 1
    image, same = unfilter_stream(stream, height, width, 3)
    assert same and not image.any()


def test_a_sum_carried_across_skipped_words_fills_them():
    # One set byte early in a Sub row: every later pixel holds it, though their words are zero.
    width = 64
    stream = np.zeros(1 + width, np.uint8)
    stream[0], stream[1 + 2] = 1, 200
    image, _ = unfilter_stream(stream, 1, width, 1)
    assert list(image[0, :2]) == [0, 0] and (image[0, 2:] == 200).all()
