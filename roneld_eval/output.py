"""Output folders the tool owns: one writer at a time, whole results or none, nothing foreign touched.

A folder written by a command holds a manifest (`.roneld-run.json`) naming the command and
every top-level entry it wrote. The next command into the same folder:
- takes a lock (`.roneld-lock`, flock: a dead holder releases it), or stops naming the holder;
- refuses a folder holding entries no roneld-eval command wrote, or written by another command;
- finishes or clears what an earlier, killed process left (staging, trash, a half-done commit);
- writes everything into a private staging folder, then commits it: old entries this command
  does not write are removed, new ones renamed in, the manifest written last. Signals that
  arrive during the commit are held until it is over, and a failing rename undoes the commit,
  so readers see the complete old results or the complete new ones. A commit cut short by
  SIGKILL or a power cut leaves its journal behind: readers (`show`, `compare`) refuse the
  folder as incomplete, and the next command into it replaces every entry the journal names.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import hashlib
import hmac
import json
import math
import os
import shutil
import signal
import stat
import tempfile
from pathlib import Path
from typing import Callable, Iterable, Sequence, SupportsFloat, cast

from .errors import InputError, RunInterrupted
from .signals import deferred_signals, held_signals, signal_number

# Where `run` writes without --out: a folder this repository's git ignores (out/), so a run in
# a clone never rewrites the committed results/.
DEFAULT_OUT = "out/run"
MANIFEST = ".roneld-run.json"
LOCK = ".roneld-lock"
JOURNAL = ".roneld-commit.json"
CACHE = ".roneld-cache"
STAGING_PREFIX = ".staging-"
TRASH_PREFIX = ".trash-"
MANIFEST_FORMAT = "roneld-eval output folder"

# The command whose folders may sit inside another command's (`show`'s pictures, in RUN/show by
# default, or wherever --out puts them): never foreign there.
PICTURES_COMMAND = "show"

# Entries of the tool's own bookkeeping: never results, never foreign.
_OWN_NAMES = {MANIFEST, LOCK, JOURNAL, CACHE, MANIFEST + ".tmp", JOURNAL + ".tmp"}

def is_own_entry(name: str) -> bool:
    """True for the tool's bookkeeping entries (lock, manifest, cache, staging, trash)."""
    return name in _OWN_NAMES or name.startswith((STAGING_PREFIX, TRASH_PREFIX))


# What to do about a run folder given as input whose manifest is damaged.
INPUT_RUN_REMEDY = "give a folder `roneld-eval run` wrote (run it again into this one)"


def incomplete_folder_holding(path: Path) -> Path | None:
    """The folder, `path` or one above it, whose commit was cut short (its journal is still
    there), else None: what such a folder holds may be part old, part new (synth's data/ of one
    set beside maps/ of another), so nothing may read it."""
    for where in dict.fromkeys((Path(os.path.abspath(path)), Path(os.path.realpath(path)))):  # a link's own place too
        for folder in (where, *where.parents):
            if os.path.lexists(folder / JOURNAL):
                return folder
    return None


def refuse_cut_short(*paths: str | Path | None) -> None:
    """Stop where an input lies in a folder whose commit was cut short (incomplete_folder_holding):
    a killed synth's new data/ beside its old maps/, or a run's lanes/ half put in place, was
    scored without a word. None (an optional input not given) is passed over."""
    for path in paths:
        if path is None:
            continue
        cut_short = incomplete_folder_holding(Path(path))
        if cut_short is not None:
            raise InputError(cut_short, "its content is incomplete (a command was killed while putting it in "
                                        "place): run that command again into this folder")


def _highest_missing(path: Path) -> Path | None:
    """The highest folder of `path` (itself or one above it) that does not exist yet, else None."""
    missing = None
    path = Path.cwd() / path  # not normalised: mkdir(parents=True) makes each component as written
    for folder in (path, *path.parents):
        if os.path.lexists(folder):
            break
        missing = folder
    return missing


def read_manifest(folder: Path, remedy: str = "remove the folder or choose another --out") -> dict | None:
    """The folder's manifest, or None when it has none; a manifest that is not ours is an error
    (`remedy`: what to do about it, for an output folder by default)."""
    path = Path(folder) / MANIFEST
    if not os.path.lexists(path):
        return None
    try:
        data = _read_json(path)
        if data.get("format") != MANIFEST_FORMAT or not isinstance(data.get("command"), str):
            raise ValueError("unknown format")
        entries = data.get("entries")
        if not isinstance(entries, list) or not all(isinstance(e, str) and _plain_name(e) for e in entries):
            raise ValueError("bad entry list")
        trees = data.setdefault("trees", {})  # none in a manifest of roneld-eval before 0.1.0's last round
        if not isinstance(trees, dict) or not all(name in entries and isinstance(digest, str)
                                                  for name, digest in trees.items()):
            raise ValueError("bad folder digests")
    except (OSError, ValueError, AttributeError, UnicodeError, RecursionError) as error:
        raise InputError(
            path, f"not a manifest this tool wrote ({error}); {remedy}"
        ) from None
    return data


def folder_digest(folder: Path) -> str:
    """What a folder holds, by name: every file and folder inside, however deep (links listed, not
    followed). The manifest keeps it for each folder a command wrote, so that the next command
    into the same place, which replaces that folder whole, does not remove files a user put in."""
    names = []
    for root, folders, files in os.walk(folder):
        inside = os.path.relpath(root, folder)
        names += [os.path.join(inside, name) + "/" for name in folders]
        names += [os.path.join(inside, name) for name in files if not _os_litter(name)]
    return hashlib.sha256("\n".join(sorted(names)).encode("utf-8", "surrogateescape")).hexdigest()


def _first_names(names: list[str]) -> str:
    """The first three names, and how many more: what an error about foreign files lists."""
    return ", ".join(names[:3]) + (f" and {len(names) - 3} more" if len(names) > 3 else "")


def _os_litter(name: str) -> bool:
    """A file a desktop's file browser leaves in folders it shows (not a user's to protect)."""
    return name in (".DS_Store", "Thumbs.db", "desktop.ini") or name.startswith("._")


def _plain_file_name(name: str) -> bool:
    return bool(name) and name not in (".", "..") and "/" not in name and "\0" not in name


def _plain_name(name: str) -> bool:
    return _plain_file_name(name) and not is_own_entry(name)


MAX_RECORD_BYTES = 1 << 20


def _read_json(path: Path):
    """A small JSON file of the tool's own (manifest, journal): a regular file under 1 MiB."""
    info = os.lstat(path)
    if not stat.S_ISREG(info.st_mode):
        raise ValueError("not a regular file")
    if info.st_size > MAX_RECORD_BYTES:
        raise ValueError("too large")
    with open(path, "rb") as handle:
        return json.loads(handle.read(MAX_RECORD_BYTES).decode("utf-8"))


def read_journal(folder: Path) -> dict | None:
    """What a commit into `folder` cut short by a kill was putting in place (or None): its
    command and the entries it was replacing and writing, each a plain entry of the folder,
    signed with this user's key, so that a forged journal can make the tool touch nothing, in
    the folder or outside it. The journal stays until the next commit into the folder replaces
    those entries: the folder is incomplete until then."""
    journal = Path(folder) / JOURNAL
    if not os.path.lexists(journal):
        return None
    try:
        plan = _read_json(journal)
        if not isinstance(plan, dict) or not isinstance(plan.get("command"), str):
            raise ValueError("not a commit plan")
        if not hmac.compare_digest(str(plan.get("mac", "")), _journal_mac(plan)):
            raise ValueError("not signed with this user's key")
        for key in ("entries", "old"):
            names = plan.get(key)
            if not isinstance(names, list) or not all(isinstance(n, str) and _plain_name(n) for n in names):
                raise ValueError(f"bad {key} list")
    except (OSError, ValueError, UnicodeError, RecursionError) as error:
        raise InputError(journal, f"an earlier commit into this folder was cut short and its journal cannot "
                                  f"be trusted ({error}); remove the folder and run again") from None
    return plan


class OutputFolder:
    """Exclusive use of an output folder by one command (see the module docstring).

    Use as a context manager; `staging()` gives the folder to write into and `commit()`
    puts its content in place.
    """

    def __init__(self, path: str | Path, command: str, nested: dict[str, str] | None = None):
        """`nested` names sub-folders other commands may write inside this one (e.g. `show`
        inside a run): they belong to these results, and are removed with them when replaced."""
        self.path = Path(path)
        self.command = command
        self.nested = nested or {}
        self.previous: dict | None = None
        self.committed = False
        self.incomplete = False  # an earlier commit was cut short: its journal is still here
        self._lock: int | None = None
        self._staging: Path | None = None
        self._created: Path | None = None  # the highest folder of `path` that did not exist

    @classmethod
    def check(cls, path: str | Path, command: str, nested: dict[str, str] | None = None) -> None:
        """Refuse now (InputError) what this command's folder would refuse after its work, and
        leave nothing behind: a folder created only to check is removed again."""
        folder = cls(path, command, nested)
        with folder:
            pass
        folder._remove_if_empty()

    # ---- opening ------------------------------------------------------------------------

    def __enter__(self) -> "OutputFolder":
        if self.path.exists() and not self.path.is_dir():
            raise InputError(self.path, "exists and is not a folder")
        self._created = _highest_missing(self.path)
        try:
            self.path.mkdir(parents=True, exist_ok=True)
        except OSError as error:
            raise InputError(self.path, f"cannot write results here: {error.strerror}") from None
        locked_before = os.path.lexists(self.path / LOCK)  # a command killed here left its lock file
        try:
            with deferred_signals():  # the lock file and what releases it made together: none left behind
                self._take_lock()
        except BaseException:
            self._release_lock()  # taken, then the signal that waited for it
            self._remove_if_empty()
            raise
        try:
            cut_short = read_journal(self.path)
            self.incomplete = cut_short is not None
            self._check_ownership(cut_short, locked_before)
            self._remove_leftovers()
        except BaseException:
            self._release_lock()
            raise
        return self

    def __exit__(self, kind, error, trace) -> None:
        if self.committed:
            with held_signals():  # the results are complete: a signal now must not say otherwise
                self._release_lock()
            if isinstance(error, KeyboardInterrupt):  # nor one between the commit and here
                number = signal_number(error)
                raise RunInterrupted(f"{signal.Signals(number).name} received after the results were put in "
                                     "place; they are complete", exit_code=128 + number) from None
            return
        staging = self._staging
        with deferred_signals():  # removed whole and unlocked, whatever comes meanwhile; said after
            try:
                if self._staging is not None:
                    shutil.rmtree(self._staging, ignore_errors=True)
                    self._staging = None
            finally:
                self._release_lock()
                if kind is not None:
                    self._remove_if_empty()
        renamed = self._named_as_output(error, staging)
        if renamed is not None:
            raise renamed.with_traceback(trace) from None  # --debug still shows where it failed

    def _named_as_output(self, error: BaseException | None, staging: Path | None) -> BaseException | None:
        """The error naming the file in the output folder, where it would have been, instead of
        the staging folder that is gone by now (a full disk while writing a figure or lane file);
        None when it names no staged file."""
        if isinstance(error, InputError):
            where = error.path
        elif isinstance(error, OSError) and error.errno is not None:
            where = error.filename if isinstance(error.filename, str) else None
        else:
            return None
        if staging is None or where is None or not Path(where).is_relative_to(staging):
            return None
        shown = self.path / Path(where).relative_to(staging)
        if isinstance(error, InputError):
            return InputError(shown, error.problem, error.line)
        # A plain OSError (its subclass follows from errno), whatever the original's class takes.
        return OSError(error.errno, error.strerror, str(shown), None, error.filename2)

    def _take_lock(self) -> None:
        path = self.path / LOCK
        while True:
            try:
                descriptor = os.open(path, os.O_RDWR | os.O_CREAT | getattr(os, "O_CLOEXEC", 0), 0o644)
            except OSError as error:
                raise InputError(self.path, f"cannot write results here: {error.strerror}") from None
            try:
                fcntl.flock(descriptor, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError as error:
                holder = _read_small(descriptor)
                os.close(descriptor)
                if error.errno in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
                    who = f" (pid {holder})" if holder.isdigit() else ""
                    raise InputError(self.path, f"another roneld-eval command is writing here{who}; "
                                                f"wait for it or choose another --out") from None
                raise InputError(path, f"cannot lock: {error.strerror}") from None
            # The previous holder may have removed the file between our open and flock: then
            # the lock we hold is on a file nobody else will ever open; try again.
            try:
                same = os.path.samestat(os.fstat(descriptor), os.stat(path))
            except FileNotFoundError:
                same = False
            if same:
                break
            os.close(descriptor)
        try:
            os.ftruncate(descriptor, 0)
            os.write(descriptor, str(os.getpid()).encode())
        except OSError as error:  # a full disk: the lock is given up, its file not left behind
            with contextlib.suppress(OSError):
                os.unlink(path)
            os.close(descriptor)
            raise InputError.unwritable(path, error) from None
        self._lock = descriptor

    def _release_lock(self) -> None:
        if self._lock is None:
            return
        with contextlib.suppress(OSError):
            os.unlink(self.path / LOCK)
        with contextlib.suppress(OSError):
            os.close(self._lock)
        self._lock = None

    def _remove_if_empty(self) -> None:
        """The folder, and the folders above it this command created, where nothing at all is
        left (a command into a new folder that failed): `--out parts/1` left parts/ behind."""
        if self._created is None:  # it was there before (a user's empty folder, or the current one): kept
            return
        folder = Path.cwd() / self.path  # as mkdir walked it: `a/../b` made a/ too, above a/..
        with contextlib.suppress(OSError):
            while True:
                if folder.name not in ("", ".", ".."):
                    folder.rmdir()
                if folder == self._created or folder == folder.parent:
                    return
                folder = folder.parent

    def _remove_leftovers(self) -> None:
        """Staging and trash folders of earlier killed commands (only in a folder that is ours)."""
        for entry in self.path.iterdir():
            if entry.name.startswith((STAGING_PREFIX, TRASH_PREFIX)):
                _remove(entry)

    def _check_ownership(self, plan: dict | None, locked_before: bool = False) -> None:
        manifest = read_manifest(self.path)
        listed = set(manifest["entries"]) if manifest is not None else set()
        if plan is not None:  # a cut-short commit: its entries are the tool's too
            listed |= set(plan["entries"]) | set(plan["old"])
        # Staging and trash names are the tool's only in a folder it has written to: a user's own
        # `.staging-mine` in a folder with none of its marks was taken for a leftover and deleted.
        ours = manifest is not None or plan is not None or locked_before
        foreign, nested = self._unlisted(listed, ours)
        if foreign:
            raise InputError(self.path, f"holds files roneld-eval did not write ({_first_names(foreign)}): results go "
                                        "only into a new or empty folder, or one an earlier `roneld-eval "
                                        f"{self.command}` wrote")
        self._refuse_another_commands(plan if plan is not None else manifest)
        if manifest is not None and plan is None:
            self._refuse_changed_folders(manifest)
        for name in nested:
            self._refuse_user_files_in_nested(self.path / name)
        if manifest is not None or nested or plan is not None:
            # After a cut-short commit, some of its entries may be old and some new: all go.
            entries = sorted(listed | set(nested))
            self.previous = {"command": self.command, "entries": entries}

    def _refuse_another_commands(self, record: dict | None) -> None:
        """Stop where the folder's record (a cut-short commit's plan, else the last commit's
        manifest) is of another command's results."""
        command = record["command"] if record is not None else None
        if command is not None and command != self.command:
            raise InputError(self.path, f"holds the results of `roneld-eval {command}`; write the "
                                        f"results of `roneld-eval {self.command}` to another folder")

    def _unlisted(self, listed: set[str], ours: bool) -> tuple[list[str], list[str]]:
        """(the entries no command of the tool wrote here, sorted; a nested command's folders)
        among those its records do not list; `ours`: the folder bears the tool's marks, so its
        staging and trash names are the tool's leftovers."""
        foreign, nested = [], []
        for entry in self.path.iterdir():
            leftover = entry.name.startswith((STAGING_PREFIX, TRASH_PREFIX))
            if entry.name in listed or (is_own_entry(entry.name) and (ours or not leftover)):
                continue
            if self._is_nested(entry):
                nested.append(entry.name)
            elif not _written_by(entry, PICTURES_COMMAND):
                foreign.append(entry.name)
            # else: pictures `show --out` put here (of some run, not of these results): left as they are
        return sorted(foreign), nested

    def _refuse_changed_folders(self, manifest: dict, base: Path | None = None) -> None:
        """Stop where a folder the last command wrote (into `base`, this folder by default) holds
        other names now: committing would replace it whole, with whatever a user put inside (a
        run written into synth's maps/)."""
        for name, digest in sorted(manifest["trees"].items()):
            folder = (base or self.path) / name
            if folder.is_dir() and not folder.is_symlink() and folder_digest(folder) != digest:
                raise InputError(folder, f"its files changed since `roneld-eval {manifest['command']}` wrote them "
                                         f"(names added, removed or renamed), and `roneld-eval {self.command}` would "
                                         "replace it whole: move what you put there elsewhere, or remove the folder")

    def _refuse_user_files_in_nested(self, folder: Path) -> None:
        """A nested command's folder (a run's show/) goes with the run that replaces it: not with
        files a user put in it."""
        try:
            manifest = read_manifest(folder)
        except InputError:
            return
        if manifest is None:  # a nested command killed in its first commit: nothing of a user's
            return
        foreign = sorted(entry.name for entry in folder.iterdir()
                         if entry.name not in manifest["entries"] and not is_own_entry(entry.name)
                         and not _os_litter(entry.name))
        if foreign:
            raise InputError(folder, f"holds files roneld-eval did not write ({_first_names(foreign)}), and "
                                     f"`roneld-eval {self.command}` would replace it whole: move them elsewhere, or "
                                     "remove the folder")
        self._refuse_changed_folders(manifest, folder)

    def _is_nested(self, entry: Path) -> bool:
        command = self.nested.get(entry.name)
        return command is not None and _written_by(entry, command)

    # ---- writing ------------------------------------------------------------------------

    def staging(self) -> Path:
        """The private folder to write this command's results into."""
        if self._staging is None:
            try:
                with deferred_signals():  # made and known together: a signal between left it behind
                    self._staging = Path(tempfile.mkdtemp(prefix=STAGING_PREFIX, dir=self.path))
            except OSError as error:
                raise InputError(self.path, f"cannot write results here: {error.strerror}") from None
        return self._staging

    def commit(self, then: Callable[[], None] | None = None) -> list[Path]:
        """Put the staged entries in place of the previous command's; returns the paths written.

        `then` runs once they are in place, still with signals held (e.g. dropping the cache)."""
        staging = self.staging()
        entries = sorted(entry.name for entry in staging.iterdir())
        old = sorted(self.previous["entries"]) if self.previous else []
        with held_signals():
            trash: Path | None = None
            try:
                trash = Path(tempfile.mkdtemp(prefix=TRASH_PREFIX, dir=self.path))
                plan = {"command": self.command, "entries": entries, "old": old}
                _write_atomically(self.path / JOURNAL, json.dumps({**plan, "mac": _journal_mac(plan)}))
            except OSError as error:  # a full disk: no journal, so nothing was moved yet
                if trash is not None:
                    shutil.rmtree(trash, ignore_errors=True)
                raise InputError(self.path, f"cannot write results here: {error.strerror}") from None
            self._apply(staging, trash, entries, old)
            self._staging = None
            self.committed = True
            global _commits
            _commits += 1
            if then is not None:
                then()
        return [self.path / name for name in entries]

    def _apply(self, staging: Path, trash: Path, entries: list[str], old: list[str]) -> None:
        """Move old entries to the trash and staged ones in, write the manifest, drop the journal;
        on a failing rename, undo the renames and leave the earlier results as they were."""
        renames: list[tuple[Path, Path]] = []  # done so far, to undo in reverse on failure

        def move(source: Path, target: Path) -> None:
            os.rename(source, target)
            renames.append((source, target))

        trees = {name: folder_digest(staging / name) for name in entries
                 if (staging / name).is_dir() and not (staging / name).is_symlink()}
        try:
            for name in entries + [n for n in old if n not in entries]:
                target = self.path / name
                if target.exists() or target.is_symlink():
                    move(target, trash / name)
                if name in entries:
                    move(staging / name, target)
            _write_atomically(self.path / MANIFEST, json.dumps(
                {"format": MANIFEST_FORMAT, "command": self.command, "entries": entries, "trees": trees},
                indent=1) + "\n")
        except OSError as error:
            for source, target in reversed(renames):
                with contextlib.suppress(OSError):
                    os.rename(target, source)
            if not self.incomplete:  # else the folder is as incomplete as before: the journal stays
                with contextlib.suppress(OSError):
                    os.unlink(self.path / JOURNAL)
            _remove(trash)
            where = getattr(error, "filename", None) or self.path
            raise InputError(where, f"cannot put the results in place ({error.strerror}); "
                                    f"the earlier results are unchanged") from None
        os.unlink(self.path / JOURNAL)
        _remove(trash)
        _remove(staging)


def _written_by(entry: Path, command: str) -> bool:
    """Whether `entry` is a folder (not a link) that `roneld-eval <command>` wrote."""
    if not entry.is_dir() or entry.is_symlink():
        return False
    try:
        # A command killed in its first commit left a journal and no manifest yet.
        record = read_manifest(entry) or read_journal(entry)
    except InputError:
        return False
    return record is not None and record["command"] == command


_commits = 0  # folders this process committed so far (commits_so_far)


def commits_so_far() -> int:
    """How many output folders this process has committed: an interruption that comes once a
    command's own has committed, on its way back, ends a command whose results are complete."""
    return _commits


def write_file(path: Path, data: str | bytes) -> None:
    """One file of a command's output (text as UTF-8); any OSError an InputError naming it: a
    full disk's names no file ("[Errno 28] No space left on device" alone)."""
    try:
        if isinstance(data, str):
            path.write_text(data, encoding="utf-8")
        else:
            path.write_bytes(data)
    except OSError as error:
        raise InputError.unwritable(path, error) from None


def _journal_mac(plan: dict) -> str:
    """The journal's keyed checksum (this user's secret key, as the caches'): the names it gives
    are replaced by the next command, so a journal someone else wrote must not name them."""
    from .secret_key import secret_key

    text = json.dumps([plan.get("command"), plan.get("entries"), plan.get("old")], sort_keys=True)
    return hmac.new(secret_key(lambda note: None), text.encode("utf-8", "surrogatepass"), hashlib.sha256).hexdigest()


def _read_small(descriptor: int) -> str:
    try:
        return os.pread(descriptor, 32, 0).decode("ascii", "replace").strip()
    except OSError:
        return ""


def _remove(path: Path) -> None:
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path, ignore_errors=True)
    else:
        with contextlib.suppress(OSError):
            path.unlink()


def _write_atomically(path: Path, text: str) -> None:
    temporary = path.with_name(path.name + ".tmp")
    try:
        with open(temporary, "w", encoding="utf-8") as handle:
            handle.write(text)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(temporary, path)
    except BaseException:
        with contextlib.suppress(OSError):
            temporary.unlink()
        raise


def csv_float(value: object) -> str:
    """A float as every CSV the tool writes gives it: the shortest text that reads back to the same
    double (Python's repr; NaN empty), so a number equal to an official tool's, bit for bit, prints
    as that tool prints it. Markdown, LaTeX and the console round (two decimals, in percent).
    (`object`: what pandas hands a float_format.)"""
    # numpy's repr would say np.float64(...); a float32 is written as the double it is
    number = float(cast(SupportsFloat, value))
    return "" if math.isnan(number) else repr(number)


def csv_gz(header: Sequence[str], rows: Iterable[Sequence[object]]) -> bytes:
    """A CSV table ('\n' line ends, csv's minimal quoting) gzipped without a time stamp, so that
    the same rows give the same bytes (frames.csv.gz); floats are formatted by the caller."""
    import csv
    import gzip
    import io

    text = io.StringIO()
    writer = csv.writer(text, lineterminator="\n")
    writer.writerow(header)
    writer.writerows(rows)
    return gzip.compress(text.getvalue().encode("utf-8"), compresslevel=6, mtime=0)


class Staging:
    """Where one command writes its files: the staging area of an `OutputFolder` it holds.

    Nothing written here is visible in the output folder until `OutputFolder.commit()`.
    """

    def __init__(self, folder: OutputFolder):
        self.folder = folder
        self.out_dir = folder.path
        self.path = folder.staging()

    def file(self, name: str) -> Path:
        path = self.path / name
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
        except OSError as error:
            raise InputError.unwritable(self.out_dir / name, error) from None
        return path

    def write_csv(self, name: str, table) -> None:
        """A pandas DataFrame as CSV (no index, '\\n' line ends, floats as `csv_float` writes them),
        streamed: pandas formats and writes it a chunk of rows at a time, so a long run's per-frame
        table is never one string."""
        try:
            with open(self.file(name), "w", encoding="utf-8", newline="") as handle:
                table.to_csv(handle, index=False, float_format=csv_float, lineterminator="\n")
        except OSError as error:
            raise InputError.unwritable(self.out_dir / name, error) from None

    def write_text(self, name: str, text: str) -> None:
        try:
            self.file(name).write_text(text, encoding="utf-8")
        except OSError as error:
            raise InputError.unwritable(self.out_dir / name, error) from None

    def write_bytes(self, name: str, data: bytes) -> None:
        """These bytes exactly (a part's files, whose digests are of the bytes on disk)."""
        try:
            self.file(name).write_bytes(data)
        except OSError as error:
            raise InputError.unwritable(self.out_dir / name, error) from None
