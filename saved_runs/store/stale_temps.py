"""The temporary files a killed writer of named output files leaves, removed by the next writer of those names.

:func:`~saved_runs.store.files.write_atomic` writes ``NAME`` through ``.NAME.PID-HEX.tmp`` next to it; a
process killed (SIGKILL, power loss) between creating and renaming that file cannot remove it.  A
command that writes a fixed set of names into a directory (``guideway export``'s table, ``guideway
volumetric``'s grid files and per-axis tables) calls :func:`remove_own_stale_temps` with those names:
only its own kind of leftover goes (another command's, another name's, stay), only regular files (a
symlink or a directory of that name is not one the writer made, and is never followed), only of a
process no longer running (a concurrent writer's file in progress stays).
"""

from __future__ import annotations

import os
import re
import stat
from collections.abc import Iterable
from pathlib import Path

from .files import pid_alive


def own_temp_pattern(name: str) -> re.Pattern[str]:
    """The temporary names :func:`~saved_runs.store.files.create_temp` gives while writing ``name``."""
    return re.compile(rf"^\.{re.escape(name)}\.(?P<pid>\d+)-[0-9a-f]{{8}}\.tmp$")


def remove_own_stale_temps(directory: Path | str, names: Iterable[str]) -> list[str]:
    """Remove from ``directory`` the temporary files of a killed writer of any of ``names``; return the
    names removed.  A missing directory has none."""
    patterns = [own_temp_pattern(n) for n in names]
    if os.path.islink(directory):  # a linked folder is not the tool's: the writer refuses it, nothing is swept there
        return []
    try:
        entries = list(os.scandir(directory))
    except (FileNotFoundError, NotADirectoryError):
        return []
    removed = []
    for e in entries:
        m = next((m for p in patterns if (m := p.match(e.name))), None)
        if m is None or pid_alive(int(m.group("pid"))):
            continue
        try:
            if not stat.S_ISREG(os.lstat(e.path).st_mode):  # lstat: a symlink is seen as one, never followed
                continue
            os.unlink(e.path)
        except FileNotFoundError:  # removed meanwhile (another rerun)
            continue
        removed.append(e.name)
    return removed
