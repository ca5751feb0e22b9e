"""Plug-in methods in a configuration: an extractor outside the package named by its factory
("module:callable" or "file.py:callable"), checked when built, and those installed packages
register under an entry-point group."""

from __future__ import annotations

import math
import numbers
import re
from dataclasses import dataclass
from typing import Any

from .config_values import checked_text, shown
from .errors import ConfigError
from .methods import METHOD_TABLE

# The built-in extractors (roneld_eval.extract.registry); plug-ins add their own names.
METHODS = tuple(METHOD_TABLE)
# A plug-in's name becomes a folder (lanes/NAME/) and a column value: letters, digits, - _ . +
METHOD_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.+-]{0,63}")
# Python's entry-point group where installed packages register extractors by name.
ENTRY_POINT_GROUP = "roneld_eval.extractors"
# Seconds a plug-in may take on one frame before the run stops (or skips the frame).
PLUGIN_TIME_LIMIT_S = 60.0


@dataclass(frozen=True)
class PluginMethod:
    """An extractor outside the package: its method name, its factory as "module:callable"
    (or "path/to/file.py:callable"), the seconds it may take per frame, and its parameters."""

    name: str
    entry: str
    params: tuple[tuple[str, Any], ...] = ()
    time_limit_s: float = PLUGIN_TIME_LIMIT_S

    def __post_init__(self):
        check_method_name(self.name)
        if self.name in METHODS:
            raise ConfigError(f"method {self.name!r} is built in; give the plug-in another name")
        if not isinstance(self.entry, str) or not _ENTRY.fullmatch(self.entry.strip()):
            raise ConfigError(f"method {self.name!r}: entry must be 'module:callable' or 'file.py:callable', "
                              f"got {self.entry!r}")
        object.__setattr__(self, "entry", checked_text(f"methods.{self.name}.entry", self.entry.strip()))
        limit = self.time_limit_s
        if isinstance(limit, bool) or not isinstance(limit, numbers.Real) or not 0 < limit <= 86_400:
            raise ConfigError(f"methods.{self.name}.time_limit_s must be a number of seconds in (0, 86400], "
                              f"got {limit!r}")
        object.__setattr__(self, "time_limit_s", float(limit))
        params = dict(self.params)
        for key, value in params.items():
            if not isinstance(key, str) or key in ("entry", "time_limit_s"):
                raise ConfigError(f"methods.{self.name}: bad parameter name {key!r}")
            _check_param(f"methods.{self.name}.{key}", value)
        object.__setattr__(self, "params", tuple(params.items()))

    def to_table(self) -> dict[str, Any]:
        """The method's [methods.NAME] table as written to config.toml."""
        table: dict[str, Any] = {"entry": self.entry}
        if self.time_limit_s != PLUGIN_TIME_LIMIT_S:
            table["time_limit_s"] = self.time_limit_s
        table.update(self.params)
        return table


# module.sub:callable.attr, or a .py file path then :callable
_ENTRY = re.compile(r"(?:[A-Za-z_][\w]*(?:\.[A-Za-z_][\w]*)*|[^:\0]+\.py):[A-Za-z_][\w]*(?:\.[A-Za-z_][\w]*)*")


def check_method_name(name: Any) -> str:
    """A method name that can be a folder and a table cell, or ConfigError."""
    if not isinstance(name, str) or not METHOD_NAME.fullmatch(name):
        # `--set methods=[baseline]`: TOML, whose list needs its names quoted
        listed = isinstance(name, str) and any(mark in name for mark in "[]'\"")
        raise ConfigError(f"bad method name {name!r}: use letters, digits and - _ . + (at most 64, starting "
                          f"with a letter or digit)" + ("; a list is methods=baseline,roneld or, as TOML, "
                                                        "methods=[\"baseline\", \"roneld\"]" if listed else ""))
    return name


def _check_param(qualified: str, value: Any) -> None:
    """Plug-in parameters are TOML scalars or lists of them (what config.toml can write back)."""
    if isinstance(value, (list, tuple)):
        for item in value:
            _check_param(qualified, item)
        return
    if isinstance(value, str):
        checked_text(qualified, value)
    elif isinstance(value, float) and not math.isfinite(value):
        raise ConfigError(f"{qualified} must be a finite number, got {value}")
    elif not isinstance(value, (bool, int, float)):
        raise ConfigError(f"{qualified} must be a number, text, true/false or a list of them, got {shown(value)}")


def methods_from_table(table: dict[str, Any]) -> tuple[tuple[str, ...], tuple[PluginMethod, ...]]:
    """[methods.NAME] tables -> (method names in order, plug-ins among them)."""
    names, plugins = [], []
    for name, settings in table.items():
        check_method_name(name)
        if not isinstance(settings, dict):
            raise ConfigError(f"[methods.{name}] must be a table (entry = \"module:callable\", parameters)")
        names.append(name)
        if name in METHODS:
            if settings:
                raise ConfigError(f"[methods.{name}] is built in and takes no settings here (its parameters are "
                                  f"in [{METHOD_TABLE[name].section}])")
            continue
        if "entry" not in settings:
            raise ConfigError(f"[methods.{name}] needs entry = \"module:callable\"")
        settings = dict(settings)
        entry = settings.pop("entry")
        limit = settings.pop("time_limit_s", PLUGIN_TIME_LIMIT_S)
        plugins.append(PluginMethod(name, entry, tuple(settings.items()), limit))
    return tuple(names), tuple(plugins)


def installed_extractors() -> dict[str, str]:
    """Extractors installed packages register under the entry-point group: name -> entry."""
    from .entry_points import in_group

    return {point.name: point.value for point in in_group(ENTRY_POINT_GROUP)}
