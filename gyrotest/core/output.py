"""Output plumbing shared by every command: output-path checks, atomic file writes and JSON
serialisation.

Nothing here knows about the terminal. Results are dataclasses; :func:`jsonable` turns them
(and numpy scalars/arrays, NaN, paths) into plain JSON values, so every ``--json`` output and
every saved model/report uses the same rules: NaN and infinities become ``null``.
"""

from __future__ import annotations

import contextlib
import dataclasses
import datetime as _dt
import enum
import json
import math
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any

import numpy as np

from .errors import InputError


def jsonable(obj: Any) -> Any:
    """Recursively convert ``obj`` to JSON-safe Python values (NaN/inf -> None)."""
    if obj is None or isinstance(obj, (bool, str)):
        return obj
    if isinstance(obj, int) and not isinstance(obj, bool):
        return obj
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, np.generic):
        return jsonable(obj.item())
    if isinstance(obj, np.ndarray):
        return [jsonable(v) for v in obj.tolist()]
    if hasattr(obj, "to_dict") and callable(obj.to_dict):
        return jsonable(obj.to_dict())
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return {f.name: jsonable(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple, set)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, Path):
        return str(obj)
    if isinstance(obj, enum.Enum):
        return jsonable(obj.value)
    if isinstance(obj, (_dt.datetime, _dt.date)):
        return obj.isoformat()
    return str(obj)


def dumps(obj: Any, *, indent: int | None = 2) -> str:
    """JSON text of ``obj`` after :func:`jsonable` (strict JSON: no NaN)."""
    return json.dumps(jsonable(obj), indent=indent, allow_nan=False, ensure_ascii=False)


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike) -> Iterator[Path]:
    """Yield a temporary path in the destination directory; on success it is renamed over
    ``path`` (atomic on POSIX), on any error it is removed. Never leaves a half-written file.

    Use for writers that want a file name (pyarrow, matplotlib)::

        with atomic_path("out.parquet") as tmp:
            pq.write_table(table, tmp)
    """
    dest = Path(path)
    from .guard import check_write

    check_write(dest)  # never over a file this run reads (gyrotest.core.guard)
    directory = dest.parent if str(dest.parent) else Path(".")
    if not directory.exists():
        raise InputError(f"cannot write {dest}: directory {directory} does not exist")
    if dest.is_dir():
        raise InputError(f"cannot write {dest}: it is a directory; name an output file")
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{dest.name}.", suffix=".tmp" + dest.suffix,
                                   dir=directory)
    except OSError as e:
        raise InputError(f"cannot write {dest}: {e.strerror} in directory {directory}; choose "
                         "a writable directory") from None
    os.close(fd)
    tmp_path = Path(tmp)
    # mkstemp creates 0600; give the file the permissions a plain open() would (0666 & ~umask)
    os.chmod(tmp_path, 0o666 & ~_umask())
    try:
        yield tmp_path
        # os.replace renames over the name itself: a symlink at ``dest`` is replaced, never
        # followed into the file it points to
        os.replace(tmp_path, dest)
    except OSError as e:
        with contextlib.suppress(OSError):
            tmp_path.unlink()
        if e.errno is None:  # not a write failure (e.g. a library error subclassing OSError)
            raise
        raise InputError(f"cannot write {dest}: {e.strerror or e}; nothing was written (free "
                         "space or choose another location)") from None
    except BaseException:
        with contextlib.suppress(OSError):
            tmp_path.unlink()
        raise


@contextlib.contextmanager
def atomic_open(path: str | os.PathLike, mode: str = "w", **kwargs) -> Iterator[IO]:
    """Like ``open(path, mode)`` for writing, but atomic (see :func:`atomic_path`)."""
    with atomic_path(path) as tmp:
        with open(tmp, mode, **kwargs) as fh:
            yield fh


def write_text(path: str | os.PathLike, text: str) -> None:
    with atomic_open(path, "w", encoding="utf-8") as fh:
        fh.write(text)


def write_json(path: str | os.PathLike, obj: Any) -> None:
    write_text(path, dumps(obj) + "\n")


#: suffixes of the logs gyrotest writes (Parquet; Feather/Arrow IPC)
LOG_SUFFIXES = (".parquet", ".pq", ".feather", ".arrow")


def check_output_path(path: str | os.PathLike, suffixes: tuple[str, ...], what: str, *,
                      formats: str | None = None) -> Path:
    """Validate an output path before any work: a known suffix (``formats`` says which, in
    words; default ``.a or .b``) and an existing directory. InputError names ``what``."""
    p = Path(path)
    if p.suffix.lower() not in suffixes:
        raise InputError(f"{what} {p}: unknown format {p.suffix or '(none)'!r}; use "
                         + (formats or " or ".join(suffixes)))
    parent = p.parent if str(p.parent) else Path(".")
    if not parent.is_dir():
        raise InputError(f"{what} {p}: directory {parent} does not exist")
    return p


def write_rendered(*, pdf=None, pdf_bytes: bytes | None = None, html=None,
                   html_text: str | None = None, md=None, md_text: str | None = None,
                   figures: dict | None = None) -> int:
    """Write outputs that were all rendered first (so a rendering error leaves no file): the PDF
    bytes, the HTML text, the Markdown text and its figure PNGs (``figures``: path → bytes; their
    directory is created). Every file is written atomically. Returns the number of figures."""
    from pathlib import Path

    if pdf_bytes is not None:
        with atomic_path(pdf) as tmp:
            tmp.write_bytes(pdf_bytes)
    if html_text is not None:
        write_text(html, html_text)
    n = 0
    if md is not None:
        for path, png in (figures or {}).items():
            Path(path).parent.mkdir(exist_ok=True)
            with atomic_path(path) as tmp:
                tmp.write_bytes(png)
            n += 1
        write_text(md, md_text)
    return n
