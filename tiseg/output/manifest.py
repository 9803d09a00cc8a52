"""Which files of a run folder tiseg wrote there: the manifest ``.tiseg-files.json``.

Why a manifest: a file is tiseg's only because tiseg wrote it, never because of its name (a
user's own ``scene.toml`` or ``fields.nc`` must not be replaced by a run). Every writer of a run
folder (`tiseg.output.run_folder.RunFolder`, a sweep member) lists the names it is about
to write here first; a fresh run then refuses a folder holding any entry that is not listed (in
a folder without a manifest: any entry at all) unless ``--overwrite``
(`tiseg.output.run_folder.check_fresh_folder`).

The file (JSON): ``format`` = "tiseg-run-files", ``version`` = 1, ``files`` (the names, sorted)
and ``saved``: whether the run saved a checkpoint or finished. A folder whose run never got that
far (a write failed at the start, e.g. a full disk) holds only tiseg's partial output: running
again there needs no ``--overwrite``.
"""

from __future__ import annotations

import json
from pathlib import Path

MANIFEST_NAME = ".tiseg-files.json"
FORMAT = "tiseg-run-files"
VERSION = 1


class Manifest:
    """The names tiseg wrote into a folder, and whether its run saved anything."""

    def __init__(self, files=(), saved: bool = False):
        self.files = set(files)
        self.saved = bool(saved)

    @classmethod
    def read(cls, folder) -> "Manifest | None":
        """The manifest of ``folder``; None when there is none, or the file is not tiseg's."""
        try:
            d = json.loads((Path(folder) / MANIFEST_NAME).read_text(encoding="utf-8"))
        except (OSError, ValueError):
            return None
        if not (
            isinstance(d, dict)
            and d.get("format") == FORMAT
            and isinstance(d.get("files"), list)
            and all(isinstance(n, str) for n in d["files"])
        ):
            return None
        return cls(d["files"], d.get("saved") is True)

    def write(self, folder) -> None:
        from .diagnostics import write_json_atomic

        write_json_atomic(
            Path(folder) / MANIFEST_NAME,
            {
                "format": FORMAT,
                "version": VERSION,
                "files": sorted(self.files),
                "saved": self.saved,
            },
        )


def record(folder, names=(), saved: bool | None = None) -> Manifest:
    """Add ``names`` to the manifest of ``folder`` (made if there is none) before they are
    written; ``saved``: set the flag (None: keep it). The caller holds the folder's run lock."""
    m = Manifest.read(folder) or Manifest()
    new = set(names) - m.files
    if new or (saved is not None and bool(saved) != m.saved):
        m.files |= new
        if saved is not None:
            m.saved = bool(saved)
        m.write(folder)
    return m


__all__ = ["MANIFEST_NAME", "Manifest", "record"]
