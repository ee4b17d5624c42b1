"""Records on disk, streamed as they arrive, and read back (for resuming and for analysis).

A sweep's output directory holds ``sweep.json`` (the sweep's hash, job count, format) and either

* ``records.jsonl`` — JSON-lines, one record per line, flushed after every record (the default; an interrupted
  run leaves at most one partial last line, which the reader ignores and the writer cuts off before appending);
* ``records/part-NNNNN.parquet`` — Parquet (pyarrow), one file per batch of records, each written to a
  temporary name and renamed into place (an interrupted run loses at most the unwritten batch);

and ``.sweep.lock``, which a running sweep holds (:func:`directory_lock`: ``flock``, released by the kernel when
the process ends, however it ends), so that two sweeps never write one directory.

:func:`read_records` reads either (the last record of a job wins) and returns plain dicts equal to the ones
:func:`coop_ga.sweep.run` returned.
"""

from __future__ import annotations

import contextlib
import fcntl
import json
import math
import os
import socket
import sys
import time
import uuid
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

from ..errors import CoopGAError

__all__ = ["FORMATS", "RecordWriter", "SweepError", "SweepLockedError", "directory_lock", "read_meta", "read_records"]

FORMATS = ("jsonl", "parquet")
META = "sweep.json"
JSONL = "records.jsonl"
PARTS = "records"
LOCK = ".sweep.lock"


class SweepError(CoopGAError):
    """A sweep cannot run as asked (an output directory of another sweep, a missing extra, ...)."""


class SweepLockedError(SweepError):
    """The output directory is in use by another running sweep (the message names its process)."""


@contextlib.contextmanager
def directory_lock(out: str | Path) -> Iterator[Path]:
    """Hold ``out/.sweep.lock`` (created if needed) for the duration: an exclusive, non-blocking ``flock``.

    The file records who holds it (pid, host, start time, command line) for the message another sweep gets.
    The lock is the kernel's, so a sweep killed with SIGKILL leaves no stale lock; the file itself stays.

    Raises:
        SweepLockedError: another process holds the lock (wait for it to finish or choose another directory).
        SweepError: ``out`` cannot be created or is not a directory.
    """
    d = Path(out)
    try:
        d.mkdir(parents=True, exist_ok=True)
        fd = os.open(d / LOCK, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o644)
    except OSError as exc:
        raise SweepError(f"cannot use {d} as a sweep's output directory ({exc}); choose another out=") from None
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.pread(fd, 4096, 0).decode("utf-8", "replace").strip() or "a process that has not said"
            raise SweepLockedError(
                f"{d} is in use by another sweep ({holder}): wait for it to finish, or choose another output "
                "directory (records of one sweep never come from two processes)"
            ) from None
        info = f"pid {os.getpid()} on {socket.gethostname()}, since {time.strftime('%Y-%m-%d %H:%M:%S')}: "
        info += " ".join(sys.argv)[:300]
        os.ftruncate(fd, 0)
        os.pwrite(fd, info.encode() + b"\n", 0)
        try:
            yield d
        finally:
            os.ftruncate(fd, 0)  # still locked here: nobody reads a stale holder
    finally:
        os.close(fd)  # releases the lock


def _clean(x: Any) -> Any:
    """Non-finite floats → None (JSON has no NaN), tuples → lists."""
    if isinstance(x, float):
        return x if math.isfinite(x) else None
    if isinstance(x, Mapping):
        return {str(k): _clean(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_clean(v) for v in x]
    return x


def _atomic_write_text(path: Path, text: str) -> None:
    tmp = path.with_name(f".{path.name}.{uuid.uuid4().hex}.tmp")
    tmp.write_text(text)
    os.replace(tmp, path)


def read_meta(out: str | Path) -> dict[str, Any] | None:
    """The ``sweep.json`` of an output directory, or None."""
    p = Path(out) / META
    if not p.is_file():
        return None
    try:
        meta = json.loads(p.read_text())
    except json.JSONDecodeError as exc:
        raise SweepError(f"{p} is not valid JSON ({exc}); remove it or choose another output directory") from None
    return meta if isinstance(meta, dict) else None


def _pyarrow() -> Any:
    import importlib

    try:  # imported by name: pyarrow ships no type information
        pa = importlib.import_module("pyarrow")
        pq = importlib.import_module("pyarrow.parquet")
    except ImportError:
        raise SweepError(
            "format='parquet' needs pyarrow: pip install 'coop_ga[parquet]' (or use format='jsonl')"
        ) from None
    return pa, pq


def read_records(out: str | Path) -> list[dict[str, Any]]:
    """Every record stored in ``out`` (JSON-lines or Parquet), one per job (the last one wins), by job index.

    A partial last JSON line (an interrupted write) is ignored.

    Raises:
        SweepError: ``out`` is not an existing directory.
    """
    if not isinstance(out, (str, os.PathLike)):
        raise SweepError(f"out must be a directory path, got {type(out).__name__} {out!r}"[:200])
    d = Path(out)
    if not d.is_dir():
        raise SweepError(f"{d} is not a directory of sweep records (check the path; python -m coop_ga.sweep --out)")
    by_job: dict[int, dict[str, Any]] = {}
    rows: list[dict[str, Any]] = []
    if (d / JSONL).is_file():
        with open(d / JSONL, encoding="utf-8") as f:
            for line in f:
                if not line.endswith("\n"):
                    break  # the partial last line of an interrupted write
                try:
                    rows.append(json.loads(line))
                except json.JSONDecodeError:
                    continue
    if (d / PARTS).is_dir():
        _pa, pq = _pyarrow()
        for p in sorted((d / PARTS).glob("part-*.parquet")):
            table = pq.read_table(p)
            meta = table.schema.metadata or {}
            json_cols = set(json.loads(meta.get(b"json_columns", b"[]")))
            for r in table.to_pylist():
                keys = json.loads(r.pop("_keys"))
                rows.append({k: (json.loads(r[k]) if k in json_cols and r[k] is not None else r[k]) for k in keys})
    for r in rows:
        if isinstance(r, dict) and isinstance(r.get("job"), int):
            by_job[r["job"]] = r
    return [by_job[k] for k in sorted(by_job)]


class RecordWriter:
    """Append records to ``out`` as they arrive (``format`` ``"jsonl"`` or ``"parquet"``, module docstring).

    ``meta`` is written to ``sweep.json``.  Use as a context manager (closing flushes the last Parquet batch).
    """

    def __init__(self, out: str | Path, fmt: str = "jsonl", meta: Mapping[str, Any] | None = None, batch: int = 64):
        if not isinstance(fmt, str) or fmt not in FORMATS:
            raise SweepError(f"fmt: unknown record format {fmt!r}; choose one of {list(FORMATS)}")
        if not isinstance(out, (str, os.PathLike)):
            raise SweepError(f"out must be a directory path, got {type(out).__name__} {out!r}"[:200])
        if isinstance(batch, bool) or not isinstance(batch, int) or batch < 1:
            raise SweepError(f"batch must be an integer ≥ 1 (records per Parquet file), got {batch!r}")
        if meta is not None and not isinstance(meta, Mapping):
            raise SweepError(f"meta must be a mapping (written to sweep.json) or None, got {type(meta).__name__}")
        self.dir = Path(out)
        self.fmt = fmt
        self.batch = batch
        self._buf: list[dict[str, Any]] = []
        self.dir.mkdir(parents=True, exist_ok=True)
        if meta is not None:
            _atomic_write_text(self.dir / META, json.dumps(_clean(dict(meta)), indent=1) + "\n")
        self._f = None
        if fmt == "jsonl":
            path = self.dir / JSONL
            if path.is_file():  # cut off a partial last line so that appending starts on a fresh line
                data = path.read_bytes()
                if data and not data.endswith(b"\n"):
                    with open(path, "r+b") as f:
                        f.truncate(data.rfind(b"\n") + 1)
            self._f = open(path, "a", encoding="utf-8")
        else:
            _pyarrow()
            (self.dir / PARTS).mkdir(exist_ok=True)

    def write(self, rec: Mapping[str, Any]) -> None:
        """Store one record (JSON-lines: written and flushed now; Parquet: in the current batch).

        Raises:
            SweepError: ``rec`` is not a mapping with an integer ``job``, or is not JSON-able.
        """
        if not isinstance(rec, Mapping) or isinstance(rec.get("job"), bool) or not isinstance(rec.get("job"), int):
            raise SweepError(f"a record is a mapping with an integer 'job' field, got {str(rec)[:120]}")
        r = _clean(dict(rec))
        try:
            line = json.dumps(r, allow_nan=False, separators=(",", ":"))
        except (TypeError, ValueError) as exc:
            raise SweepError(f"record of job {r['job']} is not JSON-able ({exc}); store plain data") from None
        if self._f is not None:
            self._f.write(line + "\n")
            self._f.flush()
        else:
            self._buf.append(r)
            if len(self._buf) >= self.batch:
                self.flush()

    def flush(self) -> None:
        """Write the pending Parquet batch (one part file, renamed into place)."""
        if self._f is not None:
            self._f.flush()
            return
        if not self._buf:
            return
        pa, pq = _pyarrow()
        keys: list[str] = []
        for r in self._buf:
            keys.extend(k for k in r if k not in keys)
        cols: dict[str, Any] = {}
        json_cols: list[str] = []
        for k in keys:
            vals = [r.get(k) for r in self._buf]
            if any(isinstance(v, dict) for v in vals):
                arr = None
            else:
                try:
                    arr = pa.array(vals)
                except (pa.ArrowInvalid, pa.ArrowTypeError, TypeError, OverflowError):
                    arr = None
            if arr is None:  # dicts and mixed types round-trip as JSON strings
                json_cols.append(k)
                arr = pa.array([None if v is None else json.dumps(v) for v in vals], type=pa.string())
            cols[k] = arr
        cols["_keys"] = pa.array([json.dumps(list(r)) for r in self._buf], type=pa.string())
        table = pa.table(cols).replace_schema_metadata({"json_columns": json.dumps(json_cols)})
        n = len(list((self.dir / PARTS).glob("part-*.parquet")))
        final = self.dir / PARTS / f"part-{n:05d}-{uuid.uuid4().hex[:8]}.parquet"
        tmp = final.with_name(f".{final.name}.tmp")
        pq.write_table(table, tmp)
        os.replace(tmp, final)
        self._buf = []

    def close(self) -> None:
        """Flush and close."""
        self.flush()
        if self._f is not None:
            self._f.close()
            self._f = None

    def __enter__(self) -> RecordWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def clear(out: str | Path) -> None:
    """Remove the records and ``sweep.json`` of ``out`` (nothing else)."""
    d = Path(out)
    for p in (d / JSONL, d / META):
        if p.is_file():
            p.unlink()
    if (d / PARTS).is_dir():
        for p in (d / PARTS).glob("*.parquet"):
            p.unlink()
