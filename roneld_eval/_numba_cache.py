"""Where numba keeps our compiled kernels: a per-user cache folder, never inside the package.

numba's default for `cache=True` is a `__pycache__` beside the source file. In an installed
package that is site-packages/roneld_eval/*/__pycache__/, which pip does not know about: an
uninstall (e.g. by a later `pip install -e .`) leaves those folders behind, and they then
shadow the package as an empty namespace package. So every kernel is decorated with
`cached_njit`, which gives its dispatcher numba's user-provided cache locator (the one
NUMBA_CACHE_DIR selects, numba.core.caching.UserProvidedCacheLocator) on `cache_dir()`:

- NUMBA_CACHE_DIR when the user set it (in numba.config or the environment);
- else $XDG_CACHE_HOME/roneld-eval/numba, else ~/.cache/roneld-eval/numba
  (%LOCALAPPDATA%\\roneld-eval\\numba on Windows);
- else, when that cannot be written, <temp>/roneld-eval-<user>/numba;
- else no cache at all (each run compiles).

The locator is chosen when a function is decorated, from numba.config.CACHE_DIR: it is set
only for the duration of our decorations, so it works whether or not numba was imported
before us, and the user's own cached functions keep numba's defaults.

numba's own locator names an entry's folder after the absolute path of its source folder, so
every clone, virtual environment or install of the same code compiled everything again (a
second clone's first run: 32 s). Ours (`_ContentLocator`) names it after the content of the
kernel modules and numba's version instead: the same code finds the same machine code
wherever it is installed, and any change to a kernel module (a callee's too) is a new folder.
numba still checks each entry against its source file's content and the CPU it was made for.
"""

from __future__ import annotations

import functools
import getpass
import os
import stat
import sys
import tempfile
from pathlib import Path
from typing import Any

import hashlib

from .signals import deferred_signals

# A signal waits for numba's import: cut short in the initialisation of its C extensions, numba
# prints the interruption and fails for good ("ImportError: numba._devicearray failed to
# import", exit 1 with a traceback, 1 of 60 `score openlane` signalled 0.4-0.6 s in). The
# modules that import a kernel package import this module first.
with deferred_signals():
    import numba
    from numba.core import caching as _numba_caching
    from numba.core import config as _numba_config

# numba.core.config defines its settings (CACHE_DIR among them) at run time, from the
# environment, so a type checker sees none of them.
numba_config: Any = _numba_config


_PACKAGE = Path(__file__).resolve().parent
# Every module holding kernels: they call only one another, and use no other module's globals.
# The metrics' kernels are a package: every file of it counts, so a new module cannot be left out.
KERNEL_MODULES = ("extract/_kernels.py", "maps/_kernels.py") + tuple(
    sorted(path.relative_to(_PACKAGE).as_posix() for path in (_PACKAGE / "metrics" / "_kernels").glob("*.py")))


@functools.lru_cache(maxsize=None)
def kernels_digest() -> str:
    """What the compiled code depends on: the kernel modules' content and numba's version."""
    digest = hashlib.sha256(numba.__version__.encode())
    for name in KERNEL_MODULES:
        digest.update(name.encode() + b"\0" + (_PACKAGE / name).read_bytes() + b"\0")
    return digest.hexdigest()[:20]


class _ContentLocator(_numba_caching.UserProvidedCacheLocator):
    """numba's locator for a user-chosen cache folder, with each kernel module's entries in
    `<cache>/kernels-<kernels_digest>/<its package folder>` (see the module docstring)."""

    def __init__(self, py_func, py_file):
        super().__init__(py_func, py_file)
        folder = Path(py_file).resolve().parent.relative_to(_PACKAGE)
        self._cache_path = os.path.join(str(numba_config.CACHE_DIR), f"kernels-{kernels_digest()}", *folder.parts)

    @classmethod
    def from_function(cls, py_func, py_file):
        try:
            ours = Path(py_file).resolve().relative_to(_PACKAGE).as_posix() in KERNEL_MODULES
        except (OSError, ValueError):
            ours = False
        if not ours or not _DECORATING:
            return None
        return super().from_function(py_func, py_file)


class _CheckedCacheFile(_numba_caching.IndexDataCacheFile):
    """numba's cache files, a damaged entry read as a missing one (compiled again and written
    over) instead of an error in every process that loads it: numba passes over only OSError,
    and a truncated or overwritten .nbc raised EOFError, MemoryError or OverflowError from pickle.
    Unpickling damaged bytes can raise almost any exception, so any is taken as damage."""

    def load(self, key):
        try:
            return super().load(key)
        except Exception:
            return None

    def _load_index(self):
        try:
            return super()._load_index()
        except Exception:
            return {}  # saving then writes a sound index


_DECORATING = False  # True only while cached_njit decorates: numba asks every locator, for every function
if _ContentLocator not in _numba_caching.CacheImpl._locator_classes:
    _numba_caching.CacheImpl._locator_classes.insert(0, _ContentLocator)


def _writable(folder: Path) -> bool:
    try:
        folder.mkdir(parents=True, exist_ok=True)
        tempfile.TemporaryFile(dir=folder).close()
        return True
    except OSError:
        return False


def _user_name() -> str:
    try:
        return getpass.getuser()
    except Exception:  # no user name in the environment or the password database
        return str(os.getuid()) if hasattr(os, "getuid") else "user"


def user_cache_dir() -> Path:
    """Our per-user folder for numba's cache (whether or not NUMBA_CACHE_DIR is set)."""
    if sys.platform == "win32" and os.environ.get("LOCALAPPDATA"):
        base = Path(os.environ["LOCALAPPDATA"])
    elif os.environ.get("XDG_CACHE_HOME"):
        base = Path(os.environ["XDG_CACHE_HOME"])
    else:
        base = Path.home() / ".cache"
    return base / "roneld-eval" / "numba"


@functools.lru_cache(maxsize=None)
def cache_dir() -> Path | None:
    """The folder numba caches our kernels in (see the module's docstring), None if none is writable."""
    chosen = numba_config.CACHE_DIR or os.environ.get("NUMBA_CACHE_DIR")
    # A chosen folder that cannot be written (read-only, or a file) is passed over: numba would
    # otherwise write its cache beside the package's sources.
    if chosen and _writable(Path(chosen)):
        return Path(chosen)
    candidates = (user_cache_dir, lambda: Path(tempfile.gettempdir()) / f"roneld-eval-{_user_name()}" / "numba")
    for candidate in candidates:
        try:
            folder = candidate()
        except RuntimeError:  # Path.home() without a home
            continue
        if _writable(folder):
            return folder
    return None


def cached_njit(**options):
    """numba.njit(cache=True, **options), caching in `cache_dir()` instead of beside the source.

    Without any writable folder the kernels are not cached at all (numba would otherwise fall
    back to the package's own folders).
    """
    def decorate(function):
        folder = cache_dir()
        if folder is None:
            return numba.njit(**options)(function)
        global _DECORATING
        previous = numba_config.CACHE_DIR
        numba_config.CACHE_DIR = str(folder)
        _DECORATING = True
        try:
            dispatcher = numba.njit(cache=True, **options)(function)
        finally:
            _DECORATING = False
            numba_config.CACHE_DIR = previous
        files = getattr(getattr(dispatcher, "_cache", None), "_cache_file", None)
        if type(files) is _numba_caching.IndexDataCacheFile:
            files.__class__ = _CheckedCacheFile
        return dispatcher

    return decorate


def compile_now(kernel, signature: tuple) -> None:
    """Compile `kernel` for these argument types, or load them from the cache (a no-op when this
    process has them, or when numba's JIT is disabled and kernels are plain functions)."""
    compile_ = getattr(kernel, "compile", None)
    if compile_ is not None:
        compile_(signature)


def in_cache(kernel, signature: tuple) -> bool | None:
    """Whether this process has `kernel` for these argument types, or numba's cache holds them;
    None when that cannot be told (numba's cache internals changed, or no cache).

    Reads only the kernel's small cache index (numba.core.caching: the key is the one
    `Dispatcher.compile` looks up) and whether the data file it names is there, never the
    machine code: an index whose data files were deleted by hand means compiling, announced.
    """
    if tuple(signature) in getattr(kernel, "overloads", {}):
        return True
    try:
        cache = kernel._cache
        key = cache._index_key(tuple(signature), kernel.targetctx.codegen())
        files = cache._cache_file
        data_name = files._load_index().get(key)
        if data_name is None:
            return False
        data = os.stat(files._data_path(data_name))
        return stat.S_ISREG(data.st_mode) and data.st_size > 0
    except FileNotFoundError:
        return False
    except Exception:
        return None
