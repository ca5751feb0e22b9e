"""Turning a stored array into canonical uint8 maps, with checks that name the file."""

from __future__ import annotations

import numpy as np

from ..config import MapsConfig
from ..errors import InputError


def canonical_probabilities(array: np.ndarray, path, config: MapsConfig) -> np.ndarray:
    """(C, H, W) uint8 lane channels from a stored (C[+1], H, W) uint8 or float array."""
    expected = config.lane_channels + (1 if config.background_channel else 0)
    if array.ndim != 3:
        raise InputError(path, f"maps must be a (channels, height, width) array, got shape {array.shape}")
    if array.shape[0] != expected:
        raise InputError(path, f"has {array.shape[0]} channels, expected {expected}{_channels_hint(array, config)}")
    if array.shape[1] < 2 or array.shape[2] < 2:
        raise InputError(path, f"maps of {array.shape[2]}x{array.shape[1]} pixels are too small")
    lanes = array[1:] if config.background_channel else array
    if lanes.dtype == np.uint8:
        return lanes
    if lanes.dtype in (np.float16, np.float32, np.float64):
        values = np.asarray(lanes, dtype=np.float32)
        if not np.isfinite(values).all():
            raise InputError(path, "maps hold NaN or infinite values")
        low, high = float(values.min()), float(values.max())
        if low < 0 or high > 1:
            raise InputError(path, f"float maps must hold probabilities in [0, 1], found {low:g}..{high:g}")
        return np.rint(values * 255).astype(np.uint8)
    raise InputError(path, f"maps of dtype {lanes.dtype} are not supported (use uint8 0..255 or float 0..1)")


def _channels_hint(array: np.ndarray, config: MapsConfig) -> str:
    """What a wrong channel count most likely means: channels last, or a background channel."""
    expected = config.lane_channels + (1 if config.background_channel else 0)
    if array.shape[-1] in (expected, config.lane_channels, config.lane_channels + 1) and array.shape[0] > 16:
        return (f" (it looks like (height, width, channels) = {tuple(array.shape)}: store (channels, height, "
                "width), e.g. np.transpose(maps, (2, 0, 1)))")
    if array.shape[0] == config.lane_channels + 1 and not config.background_channel:
        return (" (if the first channel is background, add --set maps.background_channel=true, or "
                "background_channel = true in [maps])")
    return ""


def canonical_existence(values, path, config: MapsConfig) -> np.ndarray:
    """(C,) float64 existence probabilities in [0, 1]."""
    existence = np.asarray(values, dtype=np.float64).reshape(-1)
    if len(existence) != config.lane_channels:
        raise InputError(path, f"existence has {len(existence)} values, expected {config.lane_channels}")
    if not np.isfinite(existence).all() or existence.min() < 0 or existence.max() > 1:
        raise InputError(path, "existence values must be numbers in [0, 1]")
    return existence
