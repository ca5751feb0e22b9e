"""The bundled presets (configs/*.toml): their names, their files, and a --config value resolved
to a file or a preset (with the nearest name when it is neither)."""

from __future__ import annotations

import os
from importlib import resources
from pathlib import Path

from .errors import ConfigError

def _presets_folder() -> Path:
    """configs/ as installed (roneld_eval.configs), or beside the package in a source checkout."""
    try:
        return Path(str(resources.files("roneld_eval.configs")))
    except ModuleNotFoundError:
        return Path(__file__).resolve().parents[1] / "configs"


def preset_names() -> list[str]:
    """Names of the bundled presets (the TOML files in configs/)."""
    return sorted(entry.name[:-5] for entry in _presets_folder().iterdir() if entry.name.endswith(".toml"))


def preset_path(name: str) -> Path:
    """The file of a bundled preset."""
    if name not in preset_names():
        raise ConfigError(f"unknown preset {name!r}; presets: {', '.join(preset_names())}")
    return _presets_folder() / f"{name}.toml"


def resolve_config_path(value: str | Path) -> Path:
    """A config file path, or a preset name when no such file exists."""
    path = Path(value)
    if os.path.lexists(path):  # read (or refused: a folder, a FIFO) by the caller
        return path
    if path.suffix == "" and str(value) in preset_names():
        return preset_path(str(value))
    raise ConfigError(f"{value}: no such config file or preset{nearest(str(value), preset_names())}"
                      f"; presets: {', '.join(preset_names())}")


def is_preset(value: str | Path) -> bool:
    """Whether `--config VALUE` reads one of the bundled presets (by name or by its path)."""
    try:
        path = resolve_config_path(value).resolve()
    except (ConfigError, OSError):
        return False
    return any(path == preset_path(name).resolve() for name in preset_names())


def nearest(value: str, choices) -> str:
    """' (did you mean X?)' for the closest of `choices` to a misspelt `value`, or ''."""
    import difflib

    close = difflib.get_close_matches(value, list(choices), n=1, cutoff=0.75)
    return f" (did you mean {close[0]}?)" if close else ""
