"""Which extractor each method name means: the built-in ones and plug-ins, found by entry.

A `Method` names its factory as "module:callable" (or "path/to/file.py:callable"), so it
travels to worker processes as text and is imported there; the runner builds one extractor
per clip with `Method.build(geometry)`. Built-ins take their parameters from the
configuration's [baseline] / [roneld] sections, plug-ins from their [methods.NAME] table.
"""

from __future__ import annotations

import dataclasses
import hashlib
import importlib
import importlib.util
import os
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

from ..config import EvalConfig, PluginMethod
from ..errors import ConfigError
from ..geometry import MapGeometry
from ..methods import METHOD_TABLE
from .protocol import Extractor, ExtractorFactory


def _baseline_params(config: EvalConfig) -> dict[str, Any]:
    # The ego position judges which of a lane list's lanes are active (lane-file input only).
    return {**dataclasses.asdict(config.baseline), "ego_center_ratio": config.roneld.center_ratio}


def _roneld_params(config: EvalConfig) -> dict[str, Any]:
    return dataclasses.asdict(config.roneld)


# A built-in method's parameters, by the configuration section its facts name.
SECTION_PARAMS: dict[str, Callable[[EvalConfig], dict[str, Any]]] = {
    "baseline": _baseline_params,
    "roneld": _roneld_params,
}


@dataclass(frozen=True)
class Method:
    """One method of a run: its name, its factory's entry and parameters."""

    name: str
    entry: str
    params: tuple[tuple[str, Any], ...] = ()
    built_in: bool = False  # built-in outputs are trusted: not checked frame by frame
    kernel_groups: tuple[str, ...] = ()
    time_limit_s: float | None = None  # plug-ins: seconds one frame may take

    def factory(self) -> ExtractorFactory:
        """The callable `entry` names (imported on first use in each process)."""
        return resolve_entry(self.entry, self.name)

    def build(self, geometry: MapGeometry) -> Extractor:
        """A fresh extractor for one clip."""
        return self.factory()(geometry, dict(self.params))


def methods_of(config: EvalConfig) -> tuple[Method, ...]:
    """The configuration's methods in order, each with its factory's entry and parameters."""
    plugins = {plugin.name: plugin for plugin in config.plugins}
    out = []
    for name in config.methods:
        facts = METHOD_TABLE.get(name)
        if facts is not None:
            params = SECTION_PARAMS[facts.section](config)
            out.append(Method(name, facts.entry, tuple(params.items()), True, facts.kernel_groups))
        else:
            plugin: PluginMethod = plugins[name]
            out.append(Method(name, plugin.entry, plugin.params, False, (), plugin.time_limit_s))
    return tuple(out)


_RESOLVED: dict[str, Callable[..., Any]] = {}


def resolve_entry(entry: str, method: str = "") -> Callable[..., Any]:
    """The callable named by "package.module:callable" or "path/to/file.py:callable".

    A module is looked for on sys.path, then in the current directory (where users keep their
    own extractor scripts); a failure is one ConfigError naming the method and the entry.
    """
    found = _RESOLVED.get(entry)
    if found is not None:
        return found
    where, _, attribute = entry.rpartition(":")
    label = f"method {method!r}: " if method else ""
    try:
        module = _load_file(Path(where)) if where.endswith(".py") else _import(where)
    except ConfigError as error:
        raise ConfigError(f"{label}{error}") from None
    except (Exception, SystemExit) as error:  # the plug-in's own import failed (or exited): say which
        raise ConfigError(f"{label}importing {where!r} failed: {type(error).__name__}: {error}") from None
    value: Any = module
    for part in attribute.split("."):
        value = getattr(value, part, None)
        if value is None:
            raise ConfigError(f"{label}{where!r} has no {attribute!r} (entry {entry!r})")
    if not callable(value):
        raise ConfigError(f"{label}{entry!r} is a {type(value).__name__}, not a callable factory")
    _RESOLVED[entry] = value
    return value


def _import(name: str):
    try:
        return importlib.import_module(name)
    except ModuleNotFoundError as error:
        if error.name is None or not name.startswith(error.name.split(".")[0]):
            raise  # a module the plug-in imports is missing: the plug-in's own problem
        here = os.getcwd()
        if here in sys.path:
            raise ConfigError(f"no module named {error.name!r} (looked on sys.path and in {here})") from None
        sys.path.append(here)  # console scripts leave the current directory off sys.path
        try:
            return importlib.import_module(name)
        except ModuleNotFoundError as again:
            if again.name != error.name:
                raise
            raise ConfigError(f"no module named {error.name!r} (looked on sys.path and in {here})") from None


def _load_file(path: Path):
    path = path.expanduser().resolve()
    if not path.is_file():
        raise ConfigError(f"{path}: plug-in file not found")
    name = "roneld_eval_plugin_" + hashlib.sha1(str(path).encode()).hexdigest()[:12]
    module = sys.modules.get(name)
    if module is not None:
        return module
    if str(path.parent) not in sys.path:
        sys.path.append(str(path.parent))  # as `python file.py` would: its own modules beside it import
    spec = importlib.util.spec_from_file_location(name, path)
    if spec is None or spec.loader is None:
        raise ConfigError(f"{path}: cannot load as a Python module")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
    except BaseException:
        del sys.modules[name]
        raise
    return module


def source_fingerprint(method: Method) -> str:
    """What the resume cache must see change when a plug-in's code changes: a digest of its
    module's source file and of the plug-in's own modules it has loaded (`own_modules`);
    "" for built-ins, which the tool's version covers."""
    if method.built_in:
        return ""
    module = _module_of(method)
    path = getattr(module, "__file__", None)
    if module is None or not path or not os.path.isfile(path):
        return f"{method.entry} (no source file)"
    home, files = own_modules(module)
    digest = hashlib.sha256()
    for file in files:
        digest.update(f"{file.relative_to(home)}\0{hashlib.sha256(file.read_bytes()).hexdigest()}\0".encode(
            "utf-8", "surrogateescape"))
    return digest.hexdigest()


def _module_of(method: Method):
    """The loaded module that defines a plug-in's factory (None if it cannot be told)."""
    return sys.modules.get(getattr(method.factory(), "__module__", "") or "")


def loaded_code(methods) -> dict[str, str]:
    """path -> SHA-256 of every source file of the plug-ins among `methods` as loaded in this
    process now (`own_modules`): taken where a clip finished, after whatever the plug-in
    imported on its way (in its factory, on its first frame, through importlib into
    sys.modules), so that --resume can tell whether any of it changed since."""
    code: dict[str, str] = {}
    for method in methods:
        if method.built_in:
            continue
        module = _module_of(method)
        if module is None or not isinstance(getattr(module, "__file__", None), str):
            continue
        for file in own_modules(module)[1]:
            code[str(file)] = file_digest(file)
    return code


_DIGESTS: dict[tuple[str, int, int], str] = {}


def file_digest(path: Path) -> str:
    """SHA-256 of a file's content ('' if it cannot be read), kept per (path, size, mtime)."""
    try:
        info = os.stat(path)
        key = (str(path), info.st_size, info.st_mtime_ns)
        if key not in _DIGESTS:
            with open(path, "rb") as handle:
                _DIGESTS[key] = hashlib.sha256(handle.read()).hexdigest()
        return _DIGESTS[key]
    except OSError:
        return ""


# Folders of installed libraries: a plug-in's code beside a virtual environment is not the
# libraries in it (their versions are recorded apart).
_LIBRARY_FOLDERS = frozenset({"site-packages", "dist-packages"})


def own_modules(module) -> tuple[Path, list[Path]]:
    """(home, source files): a plug-in module's own code as loaded now. Home is its top-level
    package's folder, or the module's folder for a single file; the files are its own and those
    of every loaded module below home (its helpers: a plug-in file imports the modules beside
    it), libraries installed there and hidden folders (.venv) apart. Sorted, the module's first."""
    own_file = os.path.abspath(module.__file__)
    top = (module.__package__ or "").partition(".")[0]
    package_file = getattr(sys.modules.get(top), "__file__", None) if top else None
    home_file = os.path.abspath(package_file) if package_file else own_file
    own, home = Path(own_file).resolve(), Path(home_file).resolve().parent
    if not own.is_relative_to(home):  # a namespace package spread over folders
        home_file, home = own_file, own.parent
    # Installed as a single file among the libraries: only the files beside it, not below.
    below = home.name not in _LIBRARY_FOLDERS
    # Resolved only where the path may lie below home (as given, or with its links resolved):
    # a thousand libraries' modules are loaded.
    prefixes = tuple({str(home) + os.sep, os.path.dirname(home_file) + os.sep})
    found = set()
    for loaded in list(sys.modules.values()):
        path = getattr(loaded, "__file__", None)
        if not isinstance(path, str) or not path.endswith(".py"):
            continue
        if os.path.isabs(path) and not path.startswith(prefixes):
            continue
        file = _own_file(path, home, below)
        if file is not None:
            found.add(file)
    found.discard(own)
    return home, [own, *sorted(found)]


def _own_file(path: str, home: Path, below: bool) -> Path | None:
    """The loaded module's file where it is the plug-in's own: under `home` (directly beside it
    unless `below`), not in a library or hidden folder there; None otherwise."""
    try:
        file = Path(path).resolve()
        relative = file.relative_to(home)
    except (OSError, ValueError):
        return None
    folders = relative.parts[:-1]
    if (folders and not below) or any(part in _LIBRARY_FOLDERS or part.startswith(".") for part in folders):
        return None
    return file if file.is_file() else None


def kernel_groups(methods: tuple[Method, ...] | list[Method]) -> tuple[str, ...]:
    """The numba kernel groups these methods' extractors run."""
    return tuple(dict.fromkeys(group for method in methods for group in method.kernel_groups))


__all__ = ["Method", "methods_of", "own_modules", "resolve_entry", "source_fingerprint", "kernel_groups",
           "loaded_code", "file_digest"]
