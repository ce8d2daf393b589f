"""File helpers that know nothing of dyncatch: modes and output paths as a user expects."""

from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path


def current_umask() -> int:
    """The process's umask: from /proc where there is one (reading it there changes
    nothing, so other threads never see a different umask), else set and set back."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("Umask:"):
                return int(line.split()[1], 8)
    except OSError:
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def honour_umask(path: str | os.PathLike, mode: int = 0o666) -> None:
    """Give ``path`` the mode a plain ``open`` would have (``mode`` less the umask):
    ``tempfile.mkstemp`` creates files 0600, which an atomic write would otherwise keep."""
    os.chmod(path, mode & ~current_umask())


def check_out_dir(out: str | os.PathLike, flag: str = "--out") -> Path:
    """``out`` as a folder path to write into, or ValueError if it cannot be one (an
    existing file, or a parent that is a file), before any work is done."""
    out = Path(out)
    for p in (out, *out.parents):
        if p.exists() and not p.is_dir():
            what = "is a file" if p == out else f"is inside {p}, which is a file"
            raise ValueError(f"{flag} {out} {what}, not a folder; choose another {flag}")
    return out


def write_json(path: str | os.PathLike, obj) -> None:
    """Atomic JSON write (a crash leaves the old file or none, never half of one)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.name, suffix=".tmp")
    with os.fdopen(fd, "w") as f:
        json.dump(obj, f, indent=2)
    honour_umask(tmp)
    os.replace(tmp, path)


def read_json(path: str | os.PathLike, fix: str = "delete it to recompute it"):
    """The JSON value in ``path``, or ValueError naming the file and ``fix`` (a damaged or
    truncated file, or one that is not text)."""
    try:
        return json.loads(Path(path).read_text())
    except (UnicodeDecodeError, json.JSONDecodeError) as err:
        raise ValueError(f"{path}: not valid JSON ({err}); {fix}") from None
