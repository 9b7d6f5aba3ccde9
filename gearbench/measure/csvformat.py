"""How a measurement CSV is written: its text encoding, delimiter and decimal mark.

Lab tools write CSV in several dialects: comma-separated with a decimal point (the
format gearbench writes), semicolon-separated with a decimal comma (a European
spreadsheet's export), tab-separated.  :func:`sniff` reads the head of a file and
decides, so that any of these reads without options:

- encoding: UTF-8 (with or without a byte-order mark), else Windows-1252 (a
  spreadsheet's default on Windows); a file with NUL bytes is binary and rejected;
- delimiter: of comma, semicolon and tab, the one that splits the header into the
  most columns and every data row of the head (its first 64 KiB) into as many;
- decimal mark: a comma only when the delimiter is not a comma, some values of the
  head are written ``1,5`` and none ``1.5`` (so a file that mixes them is read with
  the point, and its comma values are named as non-numeric).
"""
from __future__ import annotations

import csv
import re
from dataclasses import dataclass
from pathlib import Path

from ..errors import CsvFormatError

DELIMITERS = {",": "comma", ";": "semicolon", "\t": "tab"}
DECIMALS = {".": "point", ",": "comma"}
_HEAD_BYTES = 1 << 16
_COMMA_NUMBER = re.compile(r"\s*[+-]?(?:\d+,\d*|,\d+)(?:[eE][+-]?\d+)?\s*")
_POINT_NUMBER = re.compile(r"\s*[+-]?(?:\d+\.\d*|\.\d+)(?:[eE][+-]?\d+)?\s*")


@dataclass(frozen=True)
class CsvFormat:
    """A CSV dialect: ``delimiter`` (``,`` ``;`` or tab), ``decimal`` (``.`` or ``,``), ``encoding``."""

    delimiter: str = ","
    decimal: str = "."
    encoding: str = "utf-8-sig"

    def describe(self) -> str:
        """``'semicolon-separated, decimal comma, utf-8-sig'``."""
        return (f"{DELIMITERS.get(self.delimiter, repr(self.delimiter))}-separated, "
                f"decimal {DECIMALS[self.decimal]}, {self.encoding}")


def check_choice(delimiter: str | None, decimal: str | None) -> list[str]:
    """Problems of a user's delimiter/decimal choice (None = sniff it)."""
    problems = []
    if delimiter is not None and (not isinstance(delimiter, str) or delimiter not in DELIMITERS):
        problems.append(f"delimiter {delimiter!r} is not one of comma (','), semicolon (';') or tab ('\\t')")
    if decimal is not None and (not isinstance(decimal, str) or decimal not in DECIMALS):
        problems.append(f"decimal {decimal!r} is not '.' or ','")
    if delimiter == "," and decimal == ",":
        problems.append("a decimal comma needs a semicolon or tab delimiter, not a comma")
    return problems


def _head(path: Path) -> tuple[str, str, bool]:
    """The first 64 KiB of ``path`` as text, the encoding that decoded it, and whether
    the file goes on beyond them."""
    try:
        with open(path, "rb") as fh:
            raw = fh.read(_HEAD_BYTES)
    except OSError as exc:
        raise CsvFormatError(f"measurement file '{path}' cannot be read: {exc.strerror or exc}") from None
    if b"\x00" in raw:
        at = raw.index(b"\x00")
        raise CsvFormatError(f"measurement file '{path}' is binary (a NUL byte at offset {at}), "
                             "not a CSV text file")
    try:
        return raw.decode("utf-8-sig"), "utf-8-sig", len(raw) == _HEAD_BYTES
    except UnicodeDecodeError as exc:
        # A multi-byte character cut by the 64 KiB boundary is not an encoding error.
        if len(raw) == _HEAD_BYTES and exc.start >= len(raw) - 3 and "end of data" in exc.reason:
            return raw[:exc.start].decode("utf-8-sig"), "utf-8-sig", True
        utf8_error = exc
    try:
        return raw.decode("cp1252"), "cp1252", len(raw) == _HEAD_BYTES
    except UnicodeDecodeError:
        raise CsvFormatError(
            f"measurement file '{path}' is not text: byte 0x{raw[utf8_error.start]:02x} at offset "
            f"{utf8_error.start} is neither UTF-8 nor Windows-1252; save it as UTF-8 CSV") from None


def _split(line: str, delimiter: str) -> list[str]:
    return next(csv.reader([line], delimiter=delimiter), [])


def sniff(path: str | Path, delimiter: str | None = None, decimal: str | None = None) -> CsvFormat:
    """The encoding, delimiter and decimal mark of a CSV file, read from its head.

    Parameters
    ----------
    path : str or Path
        The file.
    delimiter, decimal : str, optional
        Force a choice instead of sniffing it (``','``, ``';'``, ``'\\t'``; ``'.'``, ``','``).

    Raises
    ------
    CsvFormatError
        Naming the file when it is binary or not text, or when the forced choice is invalid.
    """
    path = Path(path)
    problems = check_choice(delimiter, decimal)
    if problems:
        raise CsvFormatError(f"measurement file '{path}': " + "; ".join(problems))
    text, encoding, more = _head(path)
    lines = [ln for ln in text.splitlines() if ln.strip()]
    if more:
        lines = lines[:-1]  # the last line may be cut short by the head's end
    if delimiter is None:
        delimiter = _sniff_delimiter(lines)
    if decimal is None:
        decimal = _sniff_decimal(lines[1:], delimiter)
    return CsvFormat(delimiter, decimal, encoding)


def _sniff_delimiter(lines: list[str]) -> str:
    """The delimiter that splits the header widest and every sampled row as wide."""
    if not lines:
        return ","
    best, best_key = ",", None
    for rank, d in enumerate(DELIMITERS):
        width = len(_split(lines[0], d))
        consistent = width > 1 and all(len(_split(ln, d)) == width for ln in lines[1:])
        key = (consistent, width, -rank)
        if best_key is None or key > best_key:
            best, best_key = d, key
    return best


def _sniff_decimal(rows: list[str], delimiter: str) -> str:
    if delimiter == ",":
        return "."
    fields = [f for ln in rows for f in _split(ln, delimiter)]
    comma = any(_COMMA_NUMBER.fullmatch(f) for f in fields)
    point = any(_POINT_NUMBER.fullmatch(f) for f in fields)
    return "," if comma and not point else "."


__all__ = ["CsvFormat", "CsvFormatError", "DELIMITERS", "DECIMALS", "sniff", "check_choice"]
