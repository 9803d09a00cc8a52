"""Atomic file replacement: readers see the old file or the new one, never a half-written one."""

from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path


def _default_mode() -> int:
    """Permission bits a new file gets from open(): 0o666 less the umask."""
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


def _fsync_dir(folder: Path) -> None:
    """Make the rename itself durable (best effort: not every file system allows it)."""
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


# a temporary file of `replacing` untouched for this long has no writer left (one that writes
# touches it as it goes): a killed writer's, which a later writer into the folder removes
STALE_AFTER_S = 600.0


def remove_stale_temporaries(folder, names, older_than: float = STALE_AFTER_S) -> list[Path]:
    """Remove the temporary files (``.<name>.*.tmp``) of ``names`` in ``folder`` that a killed
    writer left, those not modified for ``older_than`` seconds (a writer of another process may
    be filling a younger one); the paths removed."""
    import time

    gone = []
    now = time.time()
    for name in names:
        for p in Path(folder).glob(f".{name}.*.tmp"):
            try:
                if now - p.stat().st_mtime >= older_than:
                    p.unlink()
                    gone.append(p)
            except OSError:
                pass
    return gone


@contextlib.contextmanager
def replacing(path):
    """Yield a temporary path beside ``path``; when the block ends without an error, the
    temporary file is synced, given ``path``'s permissions (or open()'s default for a new file)
    and renamed onto ``path``; on an error it is removed and ``path`` is untouched."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    os.close(fd)
    try:
        yield Path(tmp)
        with open(tmp, "rb") as fh:
            os.fsync(fh.fileno())
        mode = path.stat().st_mode & 0o777 if path.exists() else _default_mode()
        os.chmod(tmp, mode)
        os.replace(tmp, path)
        _fsync_dir(path.parent)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
