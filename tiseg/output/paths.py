"""Where tiseg may write: safe names, no symlinks, one writer per run folder.

* `check_name` / `safe_name`: scene and sweep names become folder names (the
  default ``runs/<name>``), so they are letters, digits, ``.``, ``_``, ``+`` and ``-``,
  starting with a letter or digit: never ``..``, a hidden name, a path or an option.
* `refuse_symlinks`: the files of a run are never written through a symbolic link
  (a link inside the output folder could point anywhere).
* `RunLock`: a lock file per run folder (the maintained ``filelock`` library); a second
  writer is refused with one line naming the holder (host, process, since when). The lock file
  exists only while a run holds it: the holder removes it before letting go.
"""

from __future__ import annotations

import json
import os
import re
import socket
import time
from pathlib import Path

from ..errors import InputError

SAFE_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9._+-]{0,127}")
UNSAFE_CHARS = re.compile(r"[^A-Za-z0-9._+-]+")
LOCK_NAME = ".tiseg.lock"
_LOCKS: dict = {}  # lock file -> FileLock, one per process
HOLDER_NAME = ".tiseg.lock.json"


def check_name(name: str, key: str = "name") -> str:
    """``name`` if it is safe as a folder name, else an InputError saying what is allowed."""
    if not isinstance(name, str) or not SAFE_NAME.fullmatch(name):
        raise InputError(
            f"{key}={name!r} must be 1-128 letters, digits, '.', '_', '+' or '-', "
            f"starting with a letter or digit (it names the output folder); "
            f"e.g. {safe_name(str(name))!r}"
        )
    return name


def safe_name(text: str, fallback: str = "scene") -> str:
    """``text`` made safe as a folder name (unsafe characters become '_')."""
    s = UNSAFE_CHARS.sub("_", text).lstrip("._+-")[:128]
    return s if s and SAFE_NAME.fullmatch(s) else fallback


def refuse_symlinks(folder: Path, names) -> None:
    """InputError when one of ``folder/name`` is a symbolic link."""
    for n in names:
        p = Path(folder) / n
        if p.is_symlink():
            raise InputError(
                f"{str(p)!r} is a symbolic link; tiseg does not write through "
                "links (they may point outside the output folder): remove it"
            )


class RunLock:
    """An exclusive lock on a run folder for as long as a run writes there.

    ``acquire()`` refuses at once (no waiting) when another process holds it, naming the
    holder from ``.tiseg.lock.json``. The lock is the operating system's (``filelock``), so a
    killed holder releases it with its death; the holder file is only a description.

    The holder removes the lock file while it still holds it, so a finished run leaves none
    behind. A process that opened the file just before and locks it just after holds a lock on
    a removed file, which protects nothing: `acquire` checks that the file it locked is
    still the one in the folder, and otherwise lets go and refuses as if the folder were busy
    (it was, a moment ago)."""

    def __init__(self, folder):
        from filelock import FileLock

        self.folder = Path(folder)
        key = str((self.folder / LOCK_NAME).resolve())
        # one OS lock per folder and process, counted: a sweep task holds its member's folder
        # while its run (which locks the same folder) writes there
        if key not in _LOCKS:
            _LOCKS[key] = FileLock(key)
        self._lock = _LOCKS[key]
        self._held = False

    def acquire(self) -> "RunLock":
        from filelock import Timeout

        try:
            self._lock.acquire(timeout=0)
            self._held = True
            if self._lock.lock_counter > 1:
                return self  # this process holds it already
            if not self._locked_file_is_current():
                self._held = False
                self._lock.release()
                raise Timeout(str(self.folder / LOCK_NAME))  # its holder removed it meanwhile
        except Timeout:
            raise InputError(
                f"{str(self.folder)!r} is in use by another tiseg run "
                f"({self.holder()}); wait for it to finish or stop it"
            ) from None
        except OSError as exc:
            raise InputError(f"cannot lock {str(self.folder)!r}: {exc.strerror or exc}") from None
        try:
            (self.folder / HOLDER_NAME).write_text(
                json.dumps(
                    {
                        "host": socket.gethostname(),
                        "pid": os.getpid(),
                        "since": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
                    }
                ),
                encoding="utf-8",
            )
        except OSError:
            pass  # the description is a courtesy, the lock is the OS's
        return self

    def busy(self) -> str | None:
        """The holder's description when another process holds the lock now, else None."""
        from filelock import Timeout

        if not (self.folder / LOCK_NAME).exists() or self._lock.is_locked:
            return None
        try:
            self._lock.acquire(timeout=0)
        except Timeout:
            return self.holder()
        except OSError:
            return None
        self._remove_file()  # a lock file no one holds (a killed run's): tidy it away
        self._lock.release()
        return None

    def _locked_file_is_current(self) -> bool:
        """Whether the file this process locked is still the folder's lock file (not one that
        its last holder removed between our open and our lock)."""
        fd = getattr(getattr(self._lock, "_context", None), "lock_file_fd", None)
        try:
            now = os.stat(self.folder / LOCK_NAME)
            return fd is None or os.path.samestat(os.fstat(fd), now)
        except OSError:  # removed: ours is a file that is gone
            return False

    def _remove_file(self) -> None:
        """Remove the lock file; called while this process holds it."""
        try:
            (self.folder / LOCK_NAME).unlink(missing_ok=True)
        except OSError:
            pass  # a read-only folder: the empty file stays, harmless

    def holder(self) -> str:
        try:
            d = json.loads((self.folder / HOLDER_NAME).read_text(encoding="utf-8"))
            return f"pid {d['pid']} on {d['host']}, since {d['since']}"
        except (OSError, ValueError, KeyError, TypeError):
            return "holder unknown"

    def release(self) -> None:
        if not self._held:
            return
        self._held = False
        if self._lock.lock_counter == 1:  # the outermost holder: the folder is free
            try:
                (self.folder / HOLDER_NAME).unlink(missing_ok=True)
            except OSError:
                pass
            self._remove_file()  # before letting go, so no one else's lock file is removed
        self._lock.release()

    def __enter__(self) -> "RunLock":
        return self.acquire()

    def __exit__(self, *exc) -> None:
        self.release()
