"""CSV exports of data loggers as they come: ``,``, ``;`` or tab between fields, a decimal point or
comma, lines before the header, units in the header (``YawRate [deg/s]``) or in a row below it.
"""

from __future__ import annotations

import csv
import io as _io
import re
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..io import DataError

__all__ = ["DELIMITERS", "MAX_PREAMBLE", "CsvLog", "split_unit", "cell_number", "read_csv_log", "clock_seconds"]

DELIMITERS = (",", ";", "\t")
#: Lines before the header searched for it (a logger's preamble: device, date, comment lines).
MAX_PREAMBLE = 200
_UNIT_IN_NAME = re.compile(r"^(?P<name>.*?)\s*(?:\[(?P<b>[^\]]*)\]|\((?P<p>[^)]*)\))$")
_TIME_OF_DAY = re.compile(r"^(\d{1,2}):(\d{2}):(\d{2}(?:[.,]\d*)?)$")
_DATE_TIME = re.compile(r"^\d{4}-\d{2}-\d{2}[T ]\d")


def split_unit(cell: str) -> tuple[str, str]:
    """A header cell as name and unit: ``"YawRate [deg/s]"`` and ``"YawRate (deg/s)"`` give
    ``("YawRate", "deg/s")``; a cell without a bracketed unit gives ``(cell, "")``."""
    cell = cell.strip()
    match = _UNIT_IN_NAME.match(cell)
    if not match or not match.group("name"):
        return cell, ""
    return match.group("name"), (match.group("b") if match.group("b") is not None else match.group("p")).strip()


@dataclass(frozen=True)
class CsvLog:
    """The table of one CSV export.

    Attributes
    ----------
    header : list of str
        The header's cells as written.
    units : list of str
        Each column's unit as the file states it (header brackets or a units row), ``""`` where none.
    body : list of list of str
        The data rows (blank rows dropped).
    decimal : str
        ``"."`` or ``","``.
    """

    header: list
    units: list
    body: list
    decimal: str

    def column(self, channel: str) -> int | None:
        """Index of the column named ``channel`` (exactly, or with its unit in brackets, or else
        the one column whose name differs only in case: ``Time`` for the default ``time``), or None."""
        if channel in self.header:
            return self.header.index(channel)
        names = [split_unit(h)[0] for h in self.header]
        if channel in names:
            return names.index(channel)
        folded = [i for i, n in enumerate(names) if n.casefold() == channel.casefold()]
        return folded[0] if len(folded) == 1 else None


def _header_at(lines: list[str], names: list[str]) -> tuple[str, int]:
    """The delimiter and the index of the header row: the first row holding the most mapped names."""
    found, delimiter, at = 0, ",", 0
    for candidate in DELIMITERS:
        for i, row in enumerate(csv.reader(lines[:MAX_PREAMBLE], delimiter=candidate)):
            cells = {c.strip() for c in row} | {split_unit(c)[0] for c in row}
            named = sum(n in cells for n in names)
            if named > found:
                found, delimiter, at = named, candidate, i
    if found:
        return delimiter, at
    first = next((i for i, line in enumerate(lines) if line.strip()), 0)
    counts = [lines[first].count(d) if lines else 0 for d in DELIMITERS]
    return DELIMITERS[int(np.argmax(counts))], first


def cell_number(cell: str, decimal: str) -> float:
    """The number a cell writes with the decimal sign ``decimal`` (``"."`` or ``","``).

    Raises
    ------
    ValueError
        If the cell holds no number.
    """
    return float(cell.replace(",", ".") if decimal == "," else cell)


def _is_number(cell: str, decimal: str) -> bool:
    try:
        cell_number(cell, decimal)
    except ValueError:
        return False
    return True


def read_csv_log(path: Path, names: list[str]) -> CsvLog:
    """Read a CSV export: dialect, header row (after any preamble), units and data rows.

    Parameters
    ----------
    path : Path
        The file (UTF-8, with or without a byte-order mark, or Windows-1252).
    names : list of str
        The mapped channel names, the time's first: the header is the row holding most of them.

    Returns
    -------
    CsvLog
        The header, the units per column, the data rows and the decimal sign.
    """
    source = str(path)
    raw = path.read_bytes()
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        text = raw.decode("cp1252", errors="replace")  # many logger exports are Windows-1252
    lines = text.splitlines()
    if len(lines) < 2:
        raise DataError(f"{source}: a CSV recording needs a header row of channel names and data rows")
    delimiter, at = _header_at(lines, names)
    rows = list(csv.reader(_io.StringIO("\n".join(lines[at:])), delimiter=delimiter))
    header = [h.strip() for h in rows[0]]
    body = [[c.strip() for c in r] for r in rows[1:] if any(c.strip() for c in r)]
    # Where fields are not split by ',' a ',' inside a number is the decimal comma.
    decimal = "," if delimiter != "," and any("," in c for r in body for c in r) else "."
    log = CsvLog(header, [split_unit(h)[1] for h in header], body, decimal)
    j = log.column(names[0])
    first = body[0] if body else []
    if first and not any(_is_number(c, decimal) for c in first if c) and not (
            j is not None and j < len(first) and clock_seconds([first[j]]) is not None):
        # a units row: every cell a word, the time's no clock time
        units = [u or c.strip("[]() ") for u, c in zip(log.units, first + [""] * len(header))]
        log = CsvLog(header, units, body[1:], decimal)
    if not log.body:
        raise DataError(f"{source}: no data rows below the header; export the run's samples with it")
    return log


def clock_seconds(cells: list[str]) -> np.ndarray | None:
    """Times written as dates and clock times: seconds from the first, or None if they are not.

    Accepts ISO 8601 date-times (``2026-11-29 10:15:30.010``, ``T`` or a space between date and
    time) and clock times of one day (``10:15:30.010``, a decimal point or comma).

    Parameters
    ----------
    cells : list of str, length k
        The time column's cells.

    Returns
    -------
    ndarray, shape (k,), or None
        Seconds since the first cell.
    """
    if not cells:
        return None
    if _TIME_OF_DAY.match(cells[0]):  # the first cell tells the form; numbers leave at once
        clock = [_TIME_OF_DAY.match(c) for c in cells]
        if not all(clock):
            return None
        seconds = np.array([int(m[1]) * 3600.0 + int(m[2]) * 60.0 + float(m[3].replace(",", ".")) for m in clock])
        return seconds - seconds[0]
    if not all(_DATE_TIME.match(c) for c in cells):
        return None
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # numpy warns of a time zone's offset, which it applies
            stamps = np.array(cells, dtype="datetime64[ns]")
    except ValueError:
        return None
    return (stamps - stamps[0]).astype(np.int64) * 1e-9
