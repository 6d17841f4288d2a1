"""Nothing finished is lost: the run directory's journal, lock and history bookkeeping.

* ``append`` writes one pair record as a single ``write`` on an ``O_APPEND`` descriptor,
  (``fsync`` at most every ``FSYNC_EVERY_S``): a record is on disk whole or (killed
  mid-write, disk full) rolled back;
  ``read`` drops a torn last line *and truncates it away*, so the resumed run's first record
  starts on a fresh line instead of being glued to (and lost with) the torn one.
* ``RunLock`` is an advisory ``flock`` on ``DIR/.flexbench.lock`` holding the owner's pid: a
  second run into the same directory refuses (naming that pid) or waits; the kernel drops
  the lock when its holder dies, so a lock left by a killed run is simply taken over.
* ``run_token`` names the run a directory holds (kept in ``DIR/.flexbench-run`` until
  ``--fresh`` or an empty journal): ``record_history`` replaces that run's rows in the
  SQLite history instead of adding a duplicate run each time it is resumed.
* ``OutputError``: the run directory cannot be written (read-only, missing, disk full); the
  CLI prints its one line and exits 2.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import json
import math
import os
import sqlite3
import time
import uuid
from collections.abc import Mapping
from pathlib import Path

from reports.run import store

LOCK_NAME = ".flexbench.lock"
TOKEN_NAME = ".flexbench-run"
# errors that mean "this directory cannot take our files", not a bug
_WRITE_ERRNOS = {
    errno.ENOSPC,
    errno.EDQUOT,
    errno.EROFS,
    errno.EACCES,
    errno.EPERM,
    errno.ENOTDIR,
    errno.EISDIR,
    errno.ENOENT,
    errno.EFBIG,
}


class OutputError(Exception):
    """The run directory cannot be written; the message is one line naming the path."""


def output_error(exc: OSError, out: Path, started: bool = True) -> OutputError | None:
    """``exc`` as an ``OutputError`` when it is a write problem of the run directory
    (``started``: pairs may have finished, say where they are kept)."""
    if exc.errno not in _WRITE_ERRNOS:
        return None
    where = exc.filename or out
    why = "disk full" if exc.errno in (errno.ENOSPC, errno.EDQUOT) else exc.strerror
    kept = f"; finished pairs are kept in {Path(out) / 'partial.jsonl'} (rerun to resume)"
    return OutputError(f"--out {out}: cannot write {where}: {why}" + (kept if started else ""))


def prepare(out: Path) -> None:
    """Create ``out`` and check a file can be written there (``OutputError`` if not)."""
    try:
        out.mkdir(parents=True, exist_ok=True)
        probe = out / f".flexbench-probe-{os.getpid()}"
        probe.write_bytes(b"")
        probe.unlink()
    except OSError as exc:
        raise output_error(exc, out, started=False) or exc from None


# -- partial.jsonl ---------------------------------------------------------------------------
FSYNC_EVERY_S = 0.5  # a killed run keeps every written record (the page cache survives the
# process); fsync guards against a machine crash, and one per record (~3 ms) held up the
# runner's loop that hands the pool its next pair: at most one per this many seconds
_last_sync: dict[str, float] = {}


def append(path: Path, record: Mapping) -> None:
    """Append one record whole (one write) or not at all; fsynced at most every
    ``FSYNC_EVERY_S`` seconds."""
    data = (json.dumps(store.jsonable(record), allow_nan=False) + "\n").encode()
    try:
        fd = os.open(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
    except OSError as exc:
        raise output_error(exc, path.parent) or exc from None
    try:
        size = os.fstat(fd).st_size
        try:
            if os.write(fd, data) != len(data):
                raise OSError(errno.ENOSPC, "short write (disk full?)", str(path))
            now = time.monotonic()
            if now - _last_sync.get(str(path), -math.inf) >= FSYNC_EVERY_S:
                os.fsync(fd)
                _last_sync[str(path)] = now
        except OSError as exc:
            with contextlib.suppress(OSError):
                os.ftruncate(fd, size)  # roll the torn record back
            raise output_error(exc, path.parent) or exc from None
    finally:
        os.close(fd)


def read(path: Path) -> list[dict]:
    """Records of a journal; a torn last line (no newline or bad JSON) is cut off the file."""
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        return []
    records, good_end, pos = [], 0, 0
    for line in raw.splitlines(keepends=True):
        pos += len(line)
        try:
            rec = json.loads(line) if line.strip() else None
        except ValueError:
            rec = None
        if line.endswith(b"\n") and (rec is not None or not line.strip()):
            good_end = pos
            if isinstance(rec, dict):
                records.append(rec)
    if good_end < len(raw):
        with open(path, "r+b") as fh:
            fh.truncate(good_end)
    return records


# -- lock --------------------------------------------------------------------------------------
class LockedError(Exception):
    """Another live run holds the directory (one line, names its pid)."""


class RunLock:
    """Exclusive use of a run directory for the life of the ``with`` block.

    Parameters
    ----------
    out : the run directory (created if missing).
    wait : block until the holder finishes instead of raising ``LockedError``.
    """

    def __init__(self, out: Path, wait: bool = False) -> None:
        self.path, self.wait, self.fd = Path(out) / LOCK_NAME, wait, -1

    def __enter__(self) -> RunLock:
        prepare(self.path.parent)
        self.fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(self.fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            if not self.wait:
                holder = self.holder()
                os.close(self.fd)
                raise LockedError(
                    f"--out {self.path.parent}: another flexbench run (pid {holder}) is "
                    "writing there; pass --wait to wait for it or choose another --out"
                ) from None
            fcntl.flock(self.fd, fcntl.LOCK_EX)
        os.ftruncate(self.fd, 0)
        os.pwrite(self.fd, f"{os.getpid()}\n".encode(), 0)
        return self

    def holder(self) -> str:
        """The pid written by the lock's holder ("?" when unreadable)."""
        try:
            return os.pread(self.fd, 32, 0).decode().strip() or "?"
        except (OSError, UnicodeDecodeError):
            return "?"

    def __exit__(self, *exc: object) -> None:
        with contextlib.suppress(OSError):
            os.ftruncate(self.fd, 0)
        os.close(self.fd)  # closing drops the flock


# -- history ----------------------------------------------------------------------------------
def run_token(out: Path, new: bool) -> str:
    """The id of the run held by ``out`` (a new one when ``new``: fresh start, empty journal)."""
    path = out / TOKEN_NAME
    if not new:
        with contextlib.suppress(OSError, UnicodeDecodeError):
            token = path.read_text().strip()
            if token:
                return token
    token = f"{time.strftime('%Y%m%dT%H%M%S')}-{uuid.uuid4().hex[:12]}"
    try:
        path.write_text(token + "\n")
    except OSError as exc:
        raise output_error(exc, out) or exc from None
    return token


def record_history(path: Path, payload: Mapping, out_dir: str, elapsed_s: float, token: str) -> int:
    """``store.append_history``, then the run's earlier rows (same token) give way to the new.

    The new rows take over the old run id, so a resumed run keeps one ``runs`` row and one
    ``results`` row per pair.  Returns the run id.
    """
    try:
        return _replace_run(path, store.append_history(path, payload, out_dir, elapsed_s), token)
    except sqlite3.Error as exc:  # "database or disk is full", "readonly database"
        raise OutputError(f"--history {path}: cannot write: {exc}") from None


def _replace_run(path: Path, new: int, token: str) -> int:
    con = sqlite3.connect(path, timeout=30)
    try:
        with con:
            con.execute(
                "CREATE TABLE IF NOT EXISTS run_tokens (token TEXT PRIMARY KEY, run_id INTEGER)"
            )
            row = con.execute("SELECT run_id FROM run_tokens WHERE token = ?", (token,)).fetchone()
            if row is None or row[0] == new:
                con.execute("INSERT OR REPLACE INTO run_tokens VALUES (?, ?)", (token, new))
                return new
            old = int(row[0])
            con.execute("DELETE FROM results WHERE run_id = ?", (old,))
            con.execute("DELETE FROM runs WHERE id = ?", (old,))
            con.execute("UPDATE results SET run_id = ? WHERE run_id = ?", (old, new))
            con.execute("UPDATE runs SET id = ? WHERE id = ?", (old, new))
        return old
    finally:
        con.close()
