"""Small I/O helpers: atomic writes, a file lock between processes and the provenance line every result carries."""
from __future__ import annotations

import datetime
import functools
import os
import platform
import socket
import subprocess
import sys
import threading
import time
from contextlib import contextmanager
from pathlib import Path

import pandas as pd

from analysis.core.schema import ROOT


def head() -> str:
    """The checked-out commit, short."""
    try:
        return subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True,
                              text=True, timeout=5).stdout.strip() or "uncommitted"
    except (OSError, subprocess.SubprocessError):
        return "unknown"


_print_lock = threading.Lock()


def say(msg: str):
    """A progress line on stderr, whole even when threads print at once."""
    with _print_lock:
        print(msg, file=sys.stderr, flush=True)


LOADED = head()     # the commit whose code this process runs: a long job may outlive a later checkout


def stamp(command: str) -> str:
    """One provenance line: the command that made a result, the commit whose code made it and the machine;
    if the checkout moved on while the process ran, the line says so."""
    now = head()
    rev = LOADED if now == LOADED else f"{LOADED} (the checkout moved to {now} while it ran)"
    return (f"made by `{command}` at commit {rev} on {platform.node() or 'host'} "
            f"({os.cpu_count()} cores), {datetime.date.today().isoformat()}")


@functools.lru_cache(maxsize=None)
def yade_version() -> str:
    """The YADE Debian installed (`dpkg-query`), read the same way whether or not this process has loaded YADE,
    so one run's config.json has one text (tests/test_disk.py checks a scene's against this process's)."""
    try:
        return subprocess.run(["dpkg-query", "-W", "-f=${Version}", "yade"], capture_output=True, text=True,
                              timeout=5).stdout.strip() or "not installed"
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def provenance(threads: int) -> dict:
    """Where a run came from, for its config.json and summary.json: the commit whose code the process loaded and
    whether the checkout had uncommitted changes, the YADE and Python versions, the threads and the machine."""
    try:
        dirty = bool(subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=ROOT,
                                    capture_output=True, text=True, timeout=5).stdout.strip())
    except (OSError, subprocess.SubprocessError):
        dirty = None
    return {"commit": LOADED, "dirty": dirty, "yade": yade_version(), "python": platform.python_version(),
            "threads": threads, "machine": machine(), "host": platform.node()}


def machine() -> str:
    """The machine a benchmark ran on, as its CSVs name it."""
    return f"{platform.machine()} {os.cpu_count()} cores"


def atomic_write(path: Path, data: str | bytes):
    """Write text (or bytes) to path via a temporary file and a rename, so a crash never leaves half a file."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        if isinstance(data, bytes):
            tmp.write_bytes(data)
        else:
            tmp.write_text(data)
        tmp.replace(path)
    except BaseException:                   # a full disk or a kill mid-write: no temporary file left behind
        tmp.unlink(missing_ok=True)
        raise


def kept_each(paths: list[Path], make) -> list[dict]:
    """make(i) for each of `paths` in turn, each result kept at its path (atomically, as JSON) as it finishes and read
    back instead of made again where the path exists: a stopped run resumes at the first one it lacks (a bench
    scene's tests, one per normal stress).

    >>> import tempfile
    >>> d, made = Path(tempfile.mkdtemp()), []
    >>> def make(i):
    ...     made.append(i)
    ...     return {"i": i}
    >>> kept_each([d / "a.json", d / "b.json"], make), kept_each([d / "a.json", d / "b.json"], make), made
    ([{'i': 0}, {'i': 1}], [{'i': 0}, {'i': 1}], [0, 1])
    """
    import json
    rows = []
    for i, path in enumerate(paths):
        if Path(path).exists():
            rows.append(json.loads(Path(path).read_text()))
            continue
        rows.append(make(i))
        atomic_write(path, json.dumps(rows[-1]))
    return rows


def atomic_csv(df: pd.DataFrame, path: Path, note: str | None = None):
    """CSV with an optional leading `# note` comment line (read back with `read_table`)."""
    body = df.to_csv(index=False)
    atomic_write(path, (f"# {note}\n" if note else "") + body)


@contextmanager
def held(lock: Path, log=None, poll_s: float = 2.0, stale_s: float = 4 * 3600):
    """Hold `lock` for the block: a file made only if absent (O_EXCL), naming this host and process, removed after.
    While another live process holds it, wait (saying so once); a lock whose process on this host has died, or
    one another host has held for over `stale_s`, is taken over. For work two processes would otherwise both do,
    such as settling one bed."""
    lock = Path(lock)
    lock.parent.mkdir(parents=True, exist_ok=True)
    told = False
    while True:
        try:
            fd = os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
        except FileExistsError:
            if _abandoned(lock, stale_s):
                lock.unlink(missing_ok=True)
                continue
            if log and not told:
                log(f"waiting for {lock.name}: held by {_holder(lock) or 'another process'}")
                told = True
            time.sleep(poll_s)
            continue
        with os.fdopen(fd, "w") as f:
            f.write(f"{socket.gethostname()} {os.getpid()}")
        break
    try:
        yield
    finally:
        lock.unlink(missing_ok=True)


def _holder(lock: Path) -> str:
    try:
        return lock.read_text().strip()
    except OSError:
        return ""


def _abandoned(lock: Path, stale_s: float) -> bool:
    """The lock names a process on this host that no longer runs, or another host's that is older than `stale_s`
    (a lock still being written is not abandoned)."""
    parts = _holder(lock).split()
    if len(parts) != 2 or not parts[1].isdigit():
        return False
    if parts[0] != socket.gethostname():
        try:
            return time.time() - lock.stat().st_mtime > stale_s
        except OSError:
            return False
    try:
        os.kill(int(parts[1]), 0)
    except ProcessLookupError:
        return True
    except PermissionError:
        return False
    return False


def shown(path) -> str:
    """A path as the project names it: relative to its root when inside it."""
    path = Path(path)
    return str(path.relative_to(ROOT)) if path.is_absolute() and path.is_relative_to(ROOT) else str(path)


def read_table(path) -> pd.DataFrame:
    """Read a CSV whose comment lines start with '#'."""
    return pd.read_csv(path, comment="#")
