"""Reading the small files a user hands gyrotest — profiles, campaigns, scenarios, model and
history JSON, set-point and plateau tables — as data checked against a schema.

One path for all of them:

* :func:`read_input_bytes` looks at what the path is before opening it: missing, a directory,
  a device or a socket is one line; a FIFO (named pipe, ``<(…)``) is read as a stream to its
  end, waiting at most :data:`FIFO_WAIT_S` for data (``GYROTEST_FIFO_WAIT``), never hanging
  on a pipe with no writer; a file larger than :data:`MAX_BYTES` is refused (a profile or a
  model is kilobytes: a bigger one is not what was meant, e.g. ``/dev/urandom`` or a log).
* :func:`parse_document` decodes UTF-8 and parses TOML or JSON; a nesting too deep for the
  parser (``RecursionError``) and trees deeper than :data:`MAX_DEPTH` levels or larger than
  :data:`MAX_NODES` values are refused naming the key path, before any validator recurses.
* :func:`check_schema` checks a parsed document against a small declarative schema (types,
  required keys, finite numbers, closed key sets) and collects **every** problem, each naming
  its key path as ``[columns].temperature[1]`` or ``terms[3].coefficients[0].value``;
  :class:`DocumentError` carries them (the command line prints one line per problem).

Why not pydantic or jsonschema: what went wrong with these files was mostly not types —
TOML's own parser recursing past Python's limit, units that do not parse, a column in two
roles, dates that do not exist, a coefficient count that does not match its term, resources
out of reach — checks that are code in any validator; the type checks the schema libraries
would add are a few lines here, and either library costs 0.06–0.11 s CPU of start-up on
every command that reads a profile, a third to a half of `gyrotest info` (benchmarks/README.md,
"Damaged-input campaign").
"""

from __future__ import annotations

import json
import math
import os
import select
import stat
import time
import tomllib
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from .errors import InputError

#: largest profile/campaign/scenario/model/history/set-point file read, bytes
MAX_BYTES = 8 << 20
#: deepest nesting of tables and lists (the deepest real document, a scenario, has 4)
MAX_DEPTH = 12
#: most values in one document
MAX_NODES = 200_000
#: seconds to wait for the first data from a FIFO (and for more data once it started)
FIFO_WAIT_S = 10.0


class DocumentError(InputError):
    """Several problems in one file: ``problems`` are one line each (the command line prints
    them so); ``str()`` joins them."""

    def __init__(self, source: str, problems: list[str]):
        self.problems = [f"{source}: {p}" for p in problems]
        super().__init__("; ".join(self.problems))


def keypath(parts: Iterable[str | int]) -> str:
    """``("columns", "temperature", 1)`` → ``[columns].temperature[1]`` (a TOML key path: the
    first part is the table); JSON paths are :func:`jsonpath`."""
    parts = list(parts)
    if not parts:
        return "(top level)"
    out = f"[{parts[0]}]"
    for p in parts[1:]:
        out += f"[{p}]" if isinstance(p, int) else f".{p}"
    return out


def jsonpath(parts: Iterable[str | int]) -> str:
    """``("terms", 3, "coefficients", 0, "value")`` → ``terms[3].coefficients[0].value``."""
    out = ""
    for p in parts:
        out += f"[{p}]" if isinstance(p, int) else (f".{p}" if out else str(p))
    return out or "(top level)"


# ----------------------------------------------------------------------------- reading
def _wait_s() -> float:
    try:
        v = float(os.environ.get("GYROTEST_FIFO_WAIT", FIFO_WAIT_S))
        return v if math.isfinite(v) and v > 0 else FIFO_WAIT_S
    except ValueError:
        return FIFO_WAIT_S


def path_kind(path: str | os.PathLike) -> str:
    """'missing', 'dir', 'file', 'fifo', 'device' or 'socket' — without opening the path."""
    try:
        st = os.stat(path)
    except FileNotFoundError:
        return "missing"
    except OSError:
        return "missing"
    m = st.st_mode
    if stat.S_ISDIR(m):
        return "dir"
    if stat.S_ISREG(m):
        return "file"
    if stat.S_ISFIFO(m):
        return "fifo"
    if stat.S_ISSOCK(m):
        return "socket"
    return "device"


def read_fifo(path: str | os.PathLike, what: str, *, limit: int | None = None,
              wait_s: float | None = None, hint: str = "") -> bytes:
    """All bytes of a FIFO to its end. Opened without blocking: with no writer (or a writer
    that sends nothing) for ``wait_s`` seconds it is refused in one line instead of hanging;
    ``limit`` bounds the bytes kept in memory."""
    wait = _wait_s() if wait_s is None else wait_s
    src = os.fspath(path)
    try:
        fd = os.open(src, os.O_RDONLY | os.O_NONBLOCK)
    except OSError as e:
        raise InputError(f"{src}: cannot open the named pipe ({e.strerror})") from None
    chunks: list[bytes] = []
    total = 0
    last = time.monotonic()
    try:
        while True:
            ready, _, _ = select.select([fd], [], [], 0.1)
            if ready:
                try:
                    b = os.read(fd, 1 << 20)
                except BlockingIOError:
                    continue
                if not b:  # every writer closed: the end of the stream
                    break
                chunks.append(b)
                total += len(b)
                last = time.monotonic()
                if limit is not None and total > limit:
                    raise InputError(f"{src}: the named pipe sent more than {limit:,} bytes, "
                                     f"more than {what} can be; check what writes to it")
            elif time.monotonic() - last > wait:
                state = "no data" if not chunks else f"nothing more after {total:,} bytes"
                raise InputError(
                    f"{src}: a named pipe (FIFO) with {state} for {wait:g} s: no program is "
                    f"writing {what} into it; start the writer first, or save {what} to a file"
                    f"{hint} (GYROTEST_FIFO_WAIT sets the wait)")
    finally:
        os.close(fd)
    return b"".join(chunks)


def read_input_bytes(path: str | os.PathLike, what: str, *, limit: int = MAX_BYTES,
                     not_found: str | None = None, declare: bool = True) -> bytes:
    """The bytes of a small input file (``what``: "a profile", "the model file" ...), with a
    one-line InputError for anything that is not a readable file of at most ``limit`` bytes.
    The path is declared as an input of the run (:mod:`gyrotest.core.guard`) unless ``declare`` is
    False (a file the run updates in place, such as a model history)."""
    from .guard import declare_input

    src = os.fspath(path)
    kind = path_kind(src)
    if kind == "missing":
        raise InputError(f"{src}: {not_found or what + ' not found; check the path'}")
    if kind == "dir":
        raise InputError(f"{src}: is a directory, expected {what}")
    if kind in ("device", "socket"):
        raise InputError(f"{src}: is a {'device' if kind == 'device' else 'socket'}, not a file; "
                         f"save {what} to a file and give its path")
    if declare:
        declare_input(src, what)
    if kind == "fifo":
        return read_fifo(src, what, limit=limit)
    size = os.stat(src).st_size
    if size > limit:
        raise InputError(f"{src}: {size:,} bytes, more than {what} can be (limit {limit:,} "
                         "bytes); check the path")
    try:
        with open(src, "rb") as fh:
            return fh.read(limit + 1)
    except PermissionError:
        raise InputError(f"{src}: permission denied; make the file readable") from None
    except OSError as e:
        raise InputError(f"{src}: cannot read the file ({e.strerror})") from None


def read_table_text(path: str | os.PathLike, what: str) -> str:
    """The text of a small table (a set-point or plateau table) read with
    :func:`read_input_bytes`; gzip'd, binary or non-UTF-8 content is one line."""
    src = os.fspath(path)
    raw = read_input_bytes(src, what)
    if raw[:2] == b"\x1f\x8b":
        raise InputError(f"{src}: gzip-compressed; decompress it (gunzip) first: {what} is CSV "
                         "text")
    if b"\x00" in raw[:4096]:
        raise InputError(f"{src}: binary data, not a text table; {what} is CSV text")
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        raise InputError(f"{src}: not UTF-8 text (byte {e.start}); {what} is CSV text "
                         "(save it as UTF-8)") from None


# ----------------------------------------------------------------------------- parsing
def parse_document(raw: bytes, source: str, *, fmt: str, what: str) -> Any:
    """Parse TOML (``fmt="toml"``) or JSON text; one-line InputErrors; the tree's depth and
    size bounded (:func:`check_tree`)."""
    if raw[:2] == b"\x1f\x8b":
        raise InputError(f"{source}: gzip-compressed; decompress it (gunzip) first: {what} is "
                         f"{fmt.upper()} text")
    if b"\x00" in raw[:4096]:
        raise InputError(f"{source}: binary data, not a text file; {what} is {fmt.upper()} text")
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        raise InputError(f"{source}: not UTF-8 text (byte {e.start}); {what} is "
                         f"{fmt.upper()} text") from None
    try:
        data = tomllib.loads(text) if fmt == "toml" else json.loads(text)
    except RecursionError:
        raise InputError(f"{source}: nested too deeply for the parser; {what} has a few "
                         f"levels of tables (at most {MAX_DEPTH})") from None
    except tomllib.TOMLDecodeError as e:
        raise InputError(f"{source}: invalid TOML: {e}") from None
    except ValueError as e:  # json.JSONDecodeError, and int() of a 5000-digit number
        raise InputError(f"{source}: invalid JSON: {str(e).splitlines()[0][:160]}") from None
    check_tree(data, source, toml=(fmt == "toml"))
    return data


def check_tree(data: Any, source: str, *, toml: bool = True) -> None:
    """Depth ≤ MAX_DEPTH and ≤ MAX_NODES values, walked without recursion."""
    stack: list[tuple[Any, tuple, int]] = [(data, (), 0)]
    nodes = 0
    fmt = keypath if toml else jsonpath
    while stack:
        v, path, depth = stack.pop()
        nodes += 1
        if nodes > MAX_NODES:
            raise InputError(f"{source}: more than {MAX_NODES:,} values; not a gyrotest file "
                             "of this kind (check the path)")
        if depth > MAX_DEPTH:
            raise InputError(f"{source}: {fmt(path[:MAX_DEPTH + 1])}…: nested more than "
                             f"{MAX_DEPTH} levels deep; check the brackets")
        if isinstance(v, dict):
            stack.extend((x, (*path, str(k)), depth + 1) for k, x in v.items())
        elif isinstance(v, list):
            stack.extend((x, (*path, i), depth + 1) for i, x in enumerate(v))


def load_document(path: str | os.PathLike, *, fmt: str | None = None, what: str,
                  not_found: str | None = None, declare: bool = True) -> tuple[Any, bytes]:
    """:func:`read_input_bytes` + :func:`parse_document`; ``fmt`` from the suffix (.json:
    JSON, else TOML) when not given. Returns (data, raw bytes)."""
    src = os.fspath(path)
    raw = read_input_bytes(src, what, not_found=not_found, declare=declare)
    if fmt is None:
        fmt = "json" if Path(src).suffix.lower() == ".json" else "toml"
    return parse_document(raw, src, fmt=fmt, what=what), raw


# ----------------------------------------------------------------------------- schemas
#: a schema is: a type name ("str", "num" finite number, "pos" finite > 0, "int", "bool",
#: "any", "strs" list of strings), a list [item-schema], or a dict {key: schema} with
#: required keys marked by a trailing "!" in the key (``{"value!": "num"}``); "?" after a type
#: name allows null (``"num?"``). Dicts are closed unless they hold the key "*" (the schema of
#: any other key).
Schema = Any


def _type_ok(v: Any, t: str) -> str | None:
    """None when ``v`` is of schema type ``t``, else what it should be."""
    if "|" in t:  # a union: the first alternative's wording when none fits
        wants = [_type_ok(v, alt) for alt in t.split("|")]
        return None if any(w is None for w in wants) else " or ".join(wants)
    nullable = t.endswith("?") or t == "any"
    t = t.rstrip("?")
    if v is None:
        return None if nullable else _WANT[t]
    if t == "any":
        return None
    if t == "str":
        return None if isinstance(v, str) else _WANT[t]
    if t == "bool":
        return None if isinstance(v, bool) else _WANT[t]
    if t == "int":
        return None if isinstance(v, int) and not isinstance(v, bool) else _WANT[t]
    if t == "real":  # any number, NaN and ±inf included (an uncertainty that was not estimable)
        return None if isinstance(v, (int, float)) and not isinstance(v, bool) else _WANT["num"]
    if t in ("num", "pos"):
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            return _WANT[t]
        try:
            x = float(v)
        except OverflowError:
            return f"{_WANT[t]} within ±1.8e308"
        if not math.isfinite(x):
            return f"{_WANT[t]} (finite)"
        return None if t == "num" or x > 0 else _WANT[t]
    if t == "strs":
        return None if isinstance(v, list) and all(isinstance(x, str) for x in v) else _WANT[t]
    raise AssertionError(t)


_WANT = {"any": "a value", "str": "a string", "bool": "true or false", "int": "an integer",
         "num": "a number", "pos": "a positive number", "strs": "a list of strings"}


def _show(v: Any) -> str:
    s = repr(v)
    return s if len(s) <= 40 else s[:37] + "..."


def check_schema(data: Any, schema: Schema, *, toml: bool = False,
                 path: tuple = ()) -> list[str]:
    """Every problem of ``data`` against ``schema`` as ``"<key path>: <problem>"`` lines."""
    fmt = keypath if toml else jsonpath
    problems: list[str] = []
    stack = [(data, schema, path)]
    while stack:
        v, s, p = stack.pop()
        if isinstance(s, str):
            want = _type_ok(v, s)
            if want:
                problems.append(f"{fmt(p)}: must be {want}, got {_show(v)}")
        elif isinstance(s, list):
            if not isinstance(v, list):
                problems.append(f"{fmt(p)}: must be a list, got {_show(v)}")
                continue
            stack.extend((x, s[0], (*p, i)) for i, x in enumerate(v))
        elif isinstance(s, dict):
            if not isinstance(v, dict):
                problems.append(f"{fmt(p)}: must be a table of keys, got {_show(v)}")
                continue
            keys = {k.rstrip("!"): k.endswith("!") for k in s if k != "*"}
            for k, required in keys.items():
                if required and k not in v:
                    problems.append(f"{fmt((*p, k))}: missing (required)")
            for k, x in v.items():
                if k in keys:
                    stack.append((x, s[k + "!" if keys[k] else k], (*p, k)))
                elif "*" in s:
                    stack.append((x, s["*"], (*p, k)))
                elif toml and not p:
                    problems.append(f"[{k}]: unknown section [{k}]; known sections: "
                                    + ", ".join(f"[{x}]" for x in sorted(keys)))
                else:
                    problems.append(f"{fmt((*p, k))}: unknown key {k!r}; known keys: "
                                    + ", ".join(sorted(keys)))
    return sorted(problems, key=_natural)


def _natural(line: str) -> list:
    import re

    return [int(t) if t.isdigit() else t for t in re.split(r"(\d+)", line)]


def require(data: Any, schema: Schema, source: str, *, toml: bool = False) -> None:
    """Raise :class:`DocumentError` with every problem of ``data`` against ``schema``."""
    problems = check_schema(data, schema, toml=toml)
    if problems:
        raise DocumentError(source, problems)
