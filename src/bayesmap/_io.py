"""Files in and out: bounded reads of regular files, atomic writes, complete run folders.

Reading
    :func:`read_input` opens only regular files (a FIFO, ``/dev/zero`` or a folder is refused
    without blocking), refuses files larger than a limit before reading them, and gunzips
    with the same cap on the decompressed bytes, so a small gzip cannot expand into
    gigabytes. :class:`LineReader` streams a text log line by line, gunzipping it on the
    fly when its first bytes are gzip's. Every problem is a
    :class:`~bayesmap.errors.FormatError` naming the file.
Writing one file
    :func:`atomic_open` (and :func:`write_text`, :func:`write_bytes`, :func:`write_json`)
    write to a hidden temporary file beside the destination, ``.NAME.partial-XXXX.tmp``,
    and move it into place with :func:`os.replace`, which is atomic on POSIX and Windows.
    The file gets the permissions a plain ``open`` would give it. While it is written the
    temporary file is locked (``flock``); a temporary file that nobody holds — left by a
    process killed with SIGKILL — is removed the next time the same file is written.
Writing a run
    :func:`run_folder` gives a run a fresh hidden folder; when the run completes it writes
    ``manifest.json`` (version, command, configuration, seed, start and end time, every file
    with its size and SHA-256) and moves the folder into place, replacing the previous
    run's folder as a whole. A run that fails or is interrupted leaves nothing behind, so a
    results folder never mixes two runs, and a folder holding a manifest is complete
    (:func:`verify_run_folder` checks it).
Interruption
    Python runs ``finally`` blocks on SIGINT (``KeyboardInterrupt``) but not on SIGTERM;
    :func:`terminate_as_exit` turns SIGTERM into ``SystemExit`` so the same clean-up runs.
    A signal whose exception lands in a finaliser (``__del__``, a weakref callback: Python
    prints such an exception and drops it) is raised again every
    :data:`TERMINATE_RETRY` seconds until a clean-up is under way.
    Should that clean-up hang (a library stuck on a lock, say), the process prints every
    thread's stack to stderr and ends :data:`TERMINATE_GRACE` seconds after the signal,
    so a service manager's SIGTERM always ends it; what it left behind is swept as
    abandoned by the next write. Only the process's owner (the CLI) should install it.
"""

from __future__ import annotations

import contextlib
import faulthandler
import gzip
import hashlib
import json
import math
import os
import secrets
import shutil
import signal
import stat
import sys
import tempfile
import threading
import time
import zlib
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from types import FrameType, TracebackType
from typing import IO, Any

from bayesmap import __version__
from bayesmap.errors import ConfigError, FormatError
from bayesmap.limits import check_size

try:  # POSIX: advisory locks tell live temporaries from abandoned ones
    import fcntl
except ImportError:  # pragma: no cover - Windows: abandoned temporaries are not swept
    fcntl = None  # type: ignore[assignment]

MANIFEST = "manifest.json"
"""File name of a run folder's manifest."""
MANIFEST_FORMAT = "bayesmap-run/1"
"""Value of the manifest's ``format`` field."""
TERMINATE_GRACE = 30.0
"""Seconds a process has, after SIGTERM, to clean up before it ends without doing so [s]."""
TERMINATE_RETRY = 0.5
"""Seconds between repeats of SIGTERM's ``SystemExit`` while no clean-up has taken it [s]."""
STALE_AFTER = 10.0
"""Seconds after which an unlocked temporary file or folder counts as abandoned [s]."""
_CHUNK = 1 << 20
GZIP_MAGIC = b"\x1f\x8b"
"""The two bytes every gzip file starts with (RFC 1952, section 2.3.1)."""
MAX_LINE_BYTES = 1 << 20
"""The longest line :class:`LineReader` reads [bytes]: a log's lines are short, and a line
without end (a gzip bomb of one byte repeated) must not fill the memory."""


# ---------------------------------------------------------------------------- reading
def open_input(path: str | Path) -> tuple[IO[bytes], int]:
    """Open the regular file ``path`` for reading: ``(binary handle, size in bytes)``.

    The file is opened without blocking, so a FIFO or a device named by mistake is refused
    at once instead of waiting forever.

    Raises
    ------
    FormatError
        Missing or unreadable file, or not a regular file (a folder, FIFO or device).
    """
    name = str(path)
    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_BINARY", 0)
    try:
        fd = os.open(path, flags)
    except OSError as error:
        raise FormatError(f"cannot open the file: {error.strerror or error}", path=name) from None
    except ValueError:  # a NUL character: no file can have this name
        raise FormatError(
            "cannot open the file: its name holds a NUL character", path=name
        ) from None
    try:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode):
            raise FormatError(
                "not a regular file (a folder, FIFO or device); give the path of a file",
                path=name,
            )
        os.set_blocking(fd, True)
        return open(fd, "rb"), info.st_size
    except BaseException:
        os.close(fd)
        raise


class LineReader:
    """The lines (bytes, newline kept) of the regular file ``path``, streamed; a line ends
    at ``\\n``, ``\\r\\n`` or a lone ``\\r``, as in text mode's universal newlines.

    A file whose first two bytes are :data:`GZIP_MAGIC` is gunzipped on the fly, whatever
    its name: robot logs are often kept as ``run.log.gz`` or renamed. Use as a context
    manager; iterate for the lines. :meth:`consumed` is how far into the file on disk
    (compressed bytes for a gzip file) reading has got, for a progress bar whose total
    is :attr:`size`.

    Raises
    ------
    FormatError
        The file cannot be opened (see :func:`open_input`), or its gzip stream is corrupt
        or cut short: named with the line the stream broke in.
    """

    def __init__(self, path: str | Path) -> None:
        self.name = str(path)
        self._file, self.size = open_input(path)
        self.compressed = self._file.peek(2)[:2] == GZIP_MAGIC  # type: ignore[attr-defined]
        self._stream: IO[bytes] | gzip.GzipFile = self._file
        if self.compressed:
            self._stream = gzip.GzipFile(fileobj=self._file, mode="rb")
        self._lines = 0

    def __enter__(self) -> LineReader:
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        error: BaseException | None,
        trace: TracebackType | None,
    ) -> None:
        self._stream.close()
        self._file.close()

    def __iter__(self) -> Iterator[bytes]:
        while chunk := self.readline():
            if b"\r" not in chunk:
                yield chunk
                continue
            lines = chunk.splitlines(keepends=True)  # bytes split only at \n, \r\n and \r
            self._lines += len(lines) - 1
            yield from lines

    def readline(self, limit: int = MAX_LINE_BYTES + 1) -> bytes:
        """The next line, ``b""`` at the end of the file; at most ``limit`` bytes are read,
        and a line longer than :data:`MAX_LINE_BYTES` is an error."""
        try:
            line = self._stream.readline(min(limit, MAX_LINE_BYTES + 1))
        except (EOFError, OSError, zlib.error) as error:
            if not self.compressed:
                what = f"cannot read the file: {getattr(error, 'strerror', None) or error}"
            elif isinstance(error, EOFError):
                what = "the gzip stream is cut short"
            else:
                what = f"the gzip stream is corrupt ({error})"
            raise FormatError(what, path=self.name, line=self._lines + 1) from None
        self._lines += 1
        if len(line) > MAX_LINE_BYTES:
            raise FormatError(
                f"the line is longer than {MAX_LINE_BYTES} bytes; not a log",
                path=self.name,
                line=self._lines,
            )
        return line

    def consumed(self) -> int:
        """Bytes of the file on disk read so far."""
        return self._file.tell()


def _gunzip(data: bytes, max_bytes: int, name: str) -> bytes:
    """Decompress every gzip member of ``data``, stopping as soon as output passes the cap
    ``max_bytes``; ``name`` names the file in errors."""
    out = bytearray()
    rest = data
    while True:
        stream = zlib.decompressobj(wbits=31)
        try:
            out += stream.decompress(rest, max_bytes + 1 - len(out))
        except zlib.error as error:
            raise FormatError(f"not a valid gzip file ({error})", path=name) from None
        check_size("bytes after gunzipping", len(out), max_bytes, "max_bytes", path=name)
        if not stream.eof:
            raise FormatError("the gzip stream ends early (truncated file)", path=name)
        rest = stream.unused_data
        if not rest.strip(b"\0"):
            return bytes(out)


def read_input(path: str | Path, *, max_bytes: int, gunzip: bool = False) -> bytes:
    """The bytes of the regular file ``path`` (gunzipped if ``gunzip``), at most ``max_bytes``.

    Raises
    ------
    FormatError
        Missing or unreadable file, not a regular file, more than ``max_bytes`` bytes on
        disk or after gunzipping, or a corrupt gzip stream.
    """
    name = str(path)
    handle, size = open_input(path)
    with handle:
        check_size("bytes in the file", size, max_bytes, "max_bytes", path=name)
        try:
            data = _read_at_most(handle, max_bytes + 1, size + 1)
        except OSError as error:
            raise FormatError(
                f"cannot read the file: {error.strerror or error}", path=name
            ) from None
    check_size("bytes in the file", len(data), max_bytes, "max_bytes", path=name)
    return _gunzip(data, max_bytes, name) if gunzip else data


def _read_at_most(handle: IO[bytes], limit: int, expected: int) -> bytes:
    """Up to ``limit`` bytes of ``handle``, allocating as they come (not ``limit`` at once)."""
    chunks: list[bytes] = []
    total = 0
    want = min(expected, limit)
    while total < limit and (chunk := handle.read(min(want, limit - total))):
        chunks.append(chunk)
        total += len(chunk)
        want = _CHUNK
    return b"".join(chunks)


# ---------------------------------------------------------------------------- one file
@contextlib.contextmanager
def atomic_open(path: str | Path, mode: str = "w", **kwargs: Any) -> Iterator[IO[Any]]:
    """Open ``path`` for writing through a temporary file renamed into place on success.

    If the body raises (or the process is interrupted, see :func:`terminate_as_exit`), the
    temporary file is removed and ``path`` is left untouched. ``mode`` must be ``"w"`` or
    ``"wb"``. A parent that is not a folder raises :class:`ConfigError`.
    """
    if mode not in ("w", "wb"):
        raise ValueError(f"atomic_open writes only; got mode {mode!r}")
    target = Path(path)
    make_folder(target.parent)
    if target.is_dir():
        raise ConfigError(f"cannot write the file {str(target)!r}: it is a folder")
    prefix = f".{target.name}.partial-"
    sweep_abandoned(target.parent, prefix)
    try:
        fd, tmp_name = tempfile.mkstemp(prefix=prefix, suffix=".tmp", dir=target.parent)
    except OSError as error:
        raise ConfigError(f"cannot write in {str(target.parent)!r}: {error.strerror}") from None
    try:
        _lock(fd)
        if "b" not in mode:
            kwargs.setdefault("encoding", "utf-8")
        with os.fdopen(fd, mode, **kwargs) as handle:
            yield handle
            handle.flush()
            os.fsync(handle.fileno())
        try:
            os.chmod(tmp_name, _permissions_for(target))
            os.replace(tmp_name, target)
        except OSError as error:
            raise ConfigError(f"cannot write {str(target)!r}: {error.strerror}") from None
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp_name)
        raise


def make_folder(folder: Path) -> None:
    """Create ``folder`` and its parents; a file in the way is a :class:`ConfigError`."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except (FileExistsError, NotADirectoryError):
        raise ConfigError(
            f"cannot create the folder {str(folder)!r}: it, or one of its parents, is a file; "
            "choose another output path"
        ) from None
    except OSError as error:
        raise ConfigError(
            f"cannot create the folder {str(folder)!r}: {error.strerror or error}"
        ) from None


def _permissions_for(target: Path) -> int:
    """Mode bits for ``target``: its current mode if it exists, else ``0o666 & ~umask``."""
    try:
        return target.stat().st_mode & 0o7777
    except FileNotFoundError:
        umask = os.umask(0)
        os.umask(umask)
        return 0o666 & ~umask


def write_text(path: str | Path, text: str) -> Path:
    """Write ``text`` to ``path`` atomically and return the path."""
    with atomic_open(path, "w") as handle:
        handle.write(text)
    return Path(path)


def write_bytes(path: str | Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically and return the path."""
    with atomic_open(path, "wb") as handle:
        handle.write(data)
    return Path(path)


def write_json(path: str | Path, obj: Any) -> Path:
    """Write ``obj`` as indented JSON to ``path`` atomically (numpy scalars and arrays
    allowed).

    JSON has no NaN or infinity: a number with no defined value (a precision over no
    objects, a mean of nothing) is written as ``null``, so every reader of the standard
    can read the file.
    """
    text = json.dumps(_to_builtin(obj), indent=2, allow_nan=False)
    return write_text(path, text + "\n")


def _to_builtin(value: Any) -> Any:
    """``value`` as plain JSON types: numpy scalars and arrays as numbers and lists, paths
    as strings, tuples as lists, NaN and ±∞ as ``None``."""
    if isinstance(value, dict):
        return {key: _to_builtin(item) for key, item in value.items()}
    if isinstance(value, list | tuple):
        return [_to_builtin(item) for item in value]
    if hasattr(value, "tolist"):
        return _to_builtin(value.tolist())
    if isinstance(value, Path):
        return str(value)
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if value is None or isinstance(value, str | int | bool):
        return value
    raise TypeError(f"cannot write {type(value).__name__} as JSON")


# ---------------------------------------------------------------------------- abandoned temporaries
def _lock(fd: int) -> None:
    """Hold an exclusive advisory lock on ``fd`` until it is closed (or the process dies)."""
    if fcntl is not None:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)


def _abandoned(path: str) -> bool:
    """Whether the temporary ``path`` is old and unlocked: its writer is gone."""
    if fcntl is None:  # pragma: no cover
        return False
    try:
        if time.time() - os.lstat(path).st_mtime < STALE_AFTER:
            return False
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    except OSError:
        return False
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        return False
    finally:
        os.close(fd)
    return True


def sweep_abandoned(folder: Path, prefix: str) -> list[Path]:
    """Remove the temporary files and folders ``folder/PREFIX*.tmp`` whose writer is gone.

    A temporary is abandoned when no process holds its lock and it is older than
    :data:`STALE_AFTER` seconds; live ones, of this or any other process, are kept.
    Returns what was removed.
    """
    removed: list[Path] = []
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return removed
    for entry in entries:
        if entry.name.startswith(prefix) and entry.name.endswith(".tmp"):
            if not _abandoned(entry.path):
                continue
            if entry.is_dir(follow_symlinks=False):
                shutil.rmtree(entry.path, ignore_errors=True)
            else:
                with contextlib.suppress(FileNotFoundError):
                    os.unlink(entry.path)
            removed.append(Path(entry.path))
    return removed


# ---------------------------------------------------------------------------- run folders
@dataclass(frozen=True)
class RunFolder:
    """A run being written: write into :attr:`path`; it becomes :attr:`target` when done."""

    path: Path
    target: Path

    def final(self, written: Path) -> Path:
        """Where ``written`` (a path under :attr:`path`) will be once the run completes."""
        return self.target / Path(written).relative_to(self.path)


@contextlib.contextmanager
def run_folder(
    target: str | Path,
    *,
    command: str,
    configuration: Mapping[str, Any],
    seed: int | None,
) -> Iterator[RunFolder]:
    """Write a run into a fresh folder that replaces ``target`` only when the run completes.

    The body writes into ``folder.path`` (hidden, beside ``target``). On success
    ``manifest.json`` is written last and the folder is moved to ``target``; a previous
    run's folder there is replaced as a whole. If the body raises, or the process is
    interrupted, the new folder is removed and ``target`` keeps the previous run. Folders
    abandoned by killed runs are swept when the next run of ``target`` starts.

    Parameters
    ----------
    target
        The run's folder. If it exists it must be empty or hold a previous run (a
        ``manifest.json``): any other folder is refused rather than replaced.
    command
        What produced the run (a command line, or the function called).
    configuration
        The run's settings, as JSON-able values.
    seed
        The root seed of the run, if it has one.

    Raises
    ------
    ConfigError
        ``target`` is a file, lies under a file, or is a folder that is not a run or holds
        anything its manifest does not list (a user's file put there since, an input of
        this very run): replacing the folder would delete it.
    """
    final = Path(target)
    _check_run_folder(final)
    make_folder(final.parent)
    prefix = f".{final.name}."
    sweep_abandoned(final.parent, prefix)
    started = _now()
    try:
        work = Path(tempfile.mkdtemp(prefix=f"{prefix}run-", suffix=".tmp", dir=final.parent))
    except OSError as error:
        raise ConfigError(
            f"cannot write into the folder {str(final.parent)!r}: {error.strerror or error}"
        ) from None
    holder = os.open(work, os.O_RDONLY)
    try:
        _lock(holder)
        yield RunFolder(work, final)
        manifest = {
            "format": MANIFEST_FORMAT,
            "bayesmap_version": _version(),
            "command": command,
            "configuration": dict(configuration),
            "seed": seed,
            "started": started,
            "finished": _now(),
            "files": _inventory(work),
        }
        write_json(work / MANIFEST, manifest)
        _check_run_folder(final)
        _move_into_place(work, final, prefix)
    except BaseException:
        shutil.rmtree(work, ignore_errors=True)
        raise
    finally:
        os.close(holder)


def check_own_folder(folder: Path, marker: str, noun: str, what: str) -> None:
    """ConfigError unless ``folder`` is missing, empty, or bayesmap's own (it holds the
    ``marker`` file): a command writes only where it wrote before, never among a user's
    files. ``noun`` and ``what`` name the folder and its kind in the message."""
    if not folder.exists() and not folder.is_symlink():
        return
    if folder.is_symlink() or not folder.is_dir():
        raise ConfigError(f"the {noun} {str(folder)!r} is a file; choose another path")
    if (folder / marker).is_file() or not any(folder.iterdir()):
        return
    raise ConfigError(
        f"the {noun} {str(folder)!r} exists and holds something other than a bayesmap "
        f"{what} (it has no {marker}); choose another path or empty it"
    )


def _check_run_folder(folder: Path) -> None:
    """ConfigError unless ``folder`` may be replaced by a new run: missing, empty, or a
    previous run holding nothing but what its manifest lists."""
    check_own_folder(folder, MANIFEST, "output folder", "run")
    if not (folder / MANIFEST).is_file():
        return
    try:
        listed = {str(f["path"]) for f in json.loads((folder / MANIFEST).read_bytes())["files"]}
    except (OSError, ValueError, KeyError, TypeError):
        raise ConfigError(
            f"the output folder {str(folder)!r} has a {MANIFEST} that cannot be read; "
            "choose another path or empty it"
        ) from None
    kept = {MANIFEST, *listed}
    for name in listed:  # the folders on the way to a listed file
        parts = name.split("/")
        kept.update("/".join(parts[:k]) for k in range(1, len(parts)))
    others = sorted(
        relative
        for path in folder.rglob("*")
        if (relative := path.relative_to(folder).as_posix()) not in kept
    )
    if others:
        shown = ", ".join(repr(name) for name in others[:3])
        more = f" and {len(others) - 3} more" if len(others) > 3 else ""
        raise ConfigError(
            f"the output folder {str(folder)!r} holds {shown}{more}, which its previous run "
            "did not write, and a new run replaces the folder whole; move them out or "
            "choose another path"
        )


def _move_into_place(work: Path, final: Path, prefix: str) -> None:
    """Rename ``work`` to ``final``; an old ``final`` is first renamed aside, then deleted."""
    old = final.parent / f"{prefix}old-{secrets.token_hex(6)}.tmp"
    moved_aside = False
    if final.exists():
        os.rename(final, old)
        moved_aside = True
    try:
        os.rename(work, final)
    except BaseException:
        if moved_aside:
            os.rename(old, final)
        raise
    if moved_aside:
        shutil.rmtree(old, ignore_errors=True)


def _inventory(folder: Path) -> list[dict[str, Any]]:
    """Every file under ``folder`` (sorted): relative path, size and SHA-256."""
    files = []
    for path in sorted(p for p in folder.rglob("*") if p.is_file()):
        digest = hashlib.sha256()
        with path.open("rb") as handle:
            while chunk := handle.read(_CHUNK):
                digest.update(chunk)
        files.append(
            {
                "path": path.relative_to(folder).as_posix(),
                "bytes": path.stat().st_size,
                "sha256": digest.hexdigest(),
            }
        )
    return files


def verify_run_folder(folder: str | Path, *, hashes: bool = True) -> dict[str, Any]:
    """The manifest of a complete run folder, after checking every file it lists.

    Raises
    ------
    FormatError
        No or unreadable manifest, a listed file missing, of another size or (with
        ``hashes``) another SHA-256.
    """
    root = Path(folder)
    where = str(root / MANIFEST)
    raw = read_input(root / MANIFEST, max_bytes=1 << 26)
    try:
        manifest = json.loads(raw)
        files = manifest["files"]
        if manifest.get("format") != MANIFEST_FORMAT:
            raise ValueError(f"format is {manifest.get('format')!r}, not {MANIFEST_FORMAT!r}")
    except (ValueError, KeyError, TypeError) as error:
        raise FormatError(f"not a run manifest ({error})", path=where) from None
    for entry in files:
        path = root / entry["path"]
        if not path.is_file() or path.stat().st_size != entry["bytes"]:
            raise FormatError(f"{entry['path']} is missing or has another size", path=where)
        if hashes:
            digest = hashlib.sha256(path.read_bytes()).hexdigest()
            if digest != entry["sha256"]:
                raise FormatError(f"{entry['path']} has another SHA-256", path=where)
    return dict(manifest)


def _now() -> str:
    return datetime.now(UTC).isoformat(timespec="milliseconds")


def _version() -> str:
    return __version__


# ---------------------------------------------------------------------------- interruption
@contextlib.contextmanager
def terminate_as_exit(
    grace: float = TERMINATE_GRACE, retry: float = TERMINATE_RETRY
) -> Iterator[None]:
    """Within the block, SIGTERM raises ``SystemExit(143)`` so clean-up code runs.

    The signal also arms :mod:`faulthandler`'s watchdog (a C thread, which runs even when
    the main thread is stuck holding the interpreter lock): if the process is still alive
    ``grace`` seconds later, it writes every thread's stack to stderr and exits with
    code 1. Python runs a signal's handler wherever the main thread is, and when that is a
    finaliser (``__del__``, a weakref callback, run whenever an object is collected), it
    prints the ``SystemExit`` and drops it; so the exit is raised again every ``retry``
    seconds (``SIGALRM``) until the process is cleaning up for it — a ``SystemExit`` is
    being handled, in an ``except`` or ``finally`` block or a context manager's exit —
    which a repeat, or a second SIGTERM, never interrupts. Does nothing outside the main
    thread (where signal handlers cannot be set).
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    code = 128 + signal.SIGTERM
    alarm_before: Any = None  # the SIGALRM handler the repeats replaced, once they start
    repeating = False

    def _again(signum: int, frame: FrameType | None) -> None:
        if _exit_under_way():
            signal.setitimer(signal.ITIMER_REAL, 0.0)
            return
        raise SystemExit(code)

    def _exit(signum: int, frame: FrameType | None) -> None:
        nonlocal alarm_before, repeating
        if _exit_under_way():
            return
        if sys.__stderr__ is not None:
            faulthandler.dump_traceback_later(grace, exit=True, file=sys.__stderr__)
        if not repeating:  # SIGALRM is taken only after a SIGTERM: no one else's alarm ends us
            alarm_before, repeating = signal.signal(signal.SIGALRM, _again), True
        signal.setitimer(signal.ITIMER_REAL, retry, retry)
        raise SystemExit(code)

    previous = signal.signal(signal.SIGTERM, _exit)
    try:
        yield
    finally:
        if repeating:
            signal.setitimer(signal.ITIMER_REAL, 0.0)
            signal.signal(signal.SIGALRM, alarm_before)
        signal.signal(signal.SIGTERM, previous)


def _exit_under_way() -> bool:
    """Whether this thread is handling a ``SystemExit``: the exception being handled, or
    one it was raised while handling (a clean-up's own caught error), is one."""
    error = sys.exc_info()[1]
    while error is not None:
        if isinstance(error, SystemExit):
            return True
        error = error.__context__
    return False


__all__ = [
    "MANIFEST",
    "RunFolder",
    "atomic_open",
    "check_own_folder",
    "make_folder",
    "GZIP_MAGIC",
    "LineReader",
    "open_input",
    "read_input",
    "run_folder",
    "sweep_abandoned",
    "terminate_as_exit",
    "verify_run_folder",
    "write_bytes",
    "write_json",
    "write_text",
]
