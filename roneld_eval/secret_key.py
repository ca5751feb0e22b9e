"""This user's secret for the keyed checksums of what the tool caches between commands (the
resume cache, the ground-truth cache): a file readable by the user only, created once. Small and
without imports of the tool's stages, so that a command that only checks a checksum starts fast.
"""

from __future__ import annotations

import contextlib
import errno
import os
import secrets
import stat
from pathlib import Path
from typing import Callable


KEY_BYTES = 32


def cache_home() -> Path:
    """The tool's folder in this user's cache ($XDG_CACHE_HOME, else ~/.cache)."""
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "roneld-eval"


def key_path() -> Path:
    return cache_home() / "cache-key"


def _read_key(path: Path) -> tuple[bytes | None, str | None]:
    """(key, None) for a sound key file, else (None, why it is not used); (None, None) when absent.

    Opened without following links and without blocking (a FIFO or a link to /dev/zero must
    not stall a run), read only up to one byte past a key's size.
    """
    try:
        descriptor = os.open(path, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK)
    except FileNotFoundError:
        return None, None
    except OSError as error:
        return None, "a link" if error.errno == errno.ELOOP else f"unreadable ({error.strerror or error})"
    try:
        info = os.fstat(descriptor)
        if not stat.S_ISREG(info.st_mode):
            return None, "not a regular file"
        if hasattr(os, "getuid") and info.st_uid != os.getuid():
            return None, f"owned by another user (uid {info.st_uid})"
        if info.st_mode & 0o077:
            return None, f"readable or writable by others (mode {stat.S_IMODE(info.st_mode):o})"
        if info.st_size > 2 * KEY_BYTES + 1:  # the hex digits and a newline, nothing after them
            return None, f"not a {KEY_BYTES}-byte key ({info.st_size} bytes)"
        text = os.read(descriptor, 2 * KEY_BYTES + 2)
    except OSError as error:
        return None, f"unreadable ({error.strerror or error})"
    finally:
        os.close(descriptor)
    try:
        key = bytes.fromhex(text.decode("ascii").strip())
    except (UnicodeDecodeError, ValueError):
        key = b""
    if len(key) != KEY_BYTES:
        return None, f"not a {KEY_BYTES}-byte key ({len(text)} bytes)"
    return key, None


def secret_key(note: Callable[[str], None]) -> bytes:
    """This user's secret for the cache checksums (created once, readable by the user only).

    A key file that is empty, short, not a regular file, a link or open to others is replaced
    with a new key, with a note: entries signed with it are then recomputed, never trusted
    (an empty key would let anyone sign entries).
    """
    path = key_path()
    key, problem = _read_key(path)
    if key is not None:
        return key
    key = secrets.token_bytes(KEY_BYTES)
    temporary = path.with_name(f"cache-key.{os.getpid()}.tmp")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        descriptor = os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_TRUNC | os.O_NOFOLLOW, 0o600)
        with os.fdopen(descriptor, "w") as handle:
            handle.write(key.hex())
            handle.flush()
            os.fsync(handle.fileno())  # a crash must not leave an empty key behind the rename
        if problem is None:
            # No key yet: created only if still absent, so two runs starting at once keep one key.
            with contextlib.suppress(FileExistsError):
                os.link(temporary, path)
        else:
            os.replace(temporary, path)
    except OSError as error:
        # No writable home, or a key that cannot be replaced (a folder): entries are still
        # checked, against a key of this process only, so --resume recomputes everything
        # rather than trust what it cannot check.
        if problem is not None:
            note(f"note: {path}: the cache key is {problem} and cannot be replaced ({error.strerror or error}); "
                 "what this command caches (finished clips, drawn ground truth) cannot be reused")
        return key
    finally:
        with contextlib.suppress(OSError):
            os.unlink(temporary)
    if problem is not None:
        note(f"note: {path}: cache key replaced ({problem}); what was cached with it is computed again")
    stored, _ = _read_key(path)  # the key of a run that created it at the same moment
    return stored if stored is not None else key
