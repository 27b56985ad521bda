"""From a file's bytes to its lines: the size limit, UTF-8 decoding, line ends, and the
cell dialects (`;` or tab separators, decimal commas, quoted cells) rewritten into the
format's own (`,` between cells, `.` as decimal point) with a note."""

from __future__ import annotations

import csv
import re
import stat
import zlib
from pathlib import Path

from .errors import RecordError
from .grammar import MAX_FILE_BYTES


def read_bytes(path: Path, max_bytes: int) -> bytes:
    try:
        if not path.exists():
            raise RecordError("no such file; check the path", path)
        if path.is_dir():
            raise RecordError("is a directory, not a record file; give one of its record "
                              "files (fit, mcmc and discover take a directory; in Python: "
                              "read_campaign)", path)
        info = path.stat()
        if not stat.S_ISREG(info.st_mode):
            raise RecordError("not a regular file (a named pipe or a device); copy its "
                              "content to a file and give that", path)
        size = info.st_size
        if size > max_bytes:
            raise RecordError(
                f"file is {size / 1e6:.1f} MB, over the {max_bytes / 1e6:.0f} MB limit; "
                "split the run into several records or decimate it", path)
        with open(path, "rb") as fh:
            data = fh.read(max_bytes + 1)
    except OSError as exc:
        raise RecordError(f"cannot read the file: {exc.strerror or exc}", path) from None
    if len(data) > max_bytes:
        raise RecordError(f"file is over the {max_bytes / 1e6:.0f} MB limit", path)
    return data


def _gunzip(data: bytes, path, max_bytes: int) -> bytes:
    """The content of a gzip-compressed file, refused past `max_bytes` or when damaged."""
    inflate = zlib.decompressobj(16 + zlib.MAX_WBITS)
    try:
        out = inflate.decompress(data, max_bytes + 1)
    except zlib.error as exc:
        raise RecordError(f"gzip-compressed but damaged ({exc}); decompress it with "
                          "gunzip to see what is left", path) from None
    if len(out) > max_bytes:
        raise RecordError(f"decompressed file is over the {max_bytes / 1e6:.0f} MB limit",
                          path)
    if not inflate.eof:
        raise RecordError("gzip-compressed but cut short; copy the file again", path)
    return out


def _utf16(data: bytes) -> str | None:
    """The codec of UTF-16 text: a byte-order mark, or NUL in every other byte of ASCII
    text (a logger's 'Unicode' export without one); None for anything else."""
    if data[:2] in (b"\xff\xfe", b"\xfe\xff"):
        return "utf-16"
    head = data[:400]
    if len(head) >= 4 and len(head) % 2 == 0:
        for codec, zeros in (("utf-16-le", head[1::2]), ("utf-16-be", head[0::2])):
            if zeros.count(0) >= 0.9 * len(zeros):
                return codec
    return None


def decode(data: bytes, path, notes: list[str] | None = None,
           max_bytes: int = MAX_FILE_BYTES) -> str:
    """The text of a record file's bytes: gzip-compressed files are decompressed, UTF-16
    and Latin-1 (Windows-1252) text decoded, each with a note; UTF-8 needs none."""
    notes = [] if notes is None else notes
    if data[:2] == b"\x1f\x8b":
        data = _gunzip(data, path, max_bytes)
        notes.append("gzip-compressed: decompressed")
    codec = _utf16(data)
    if codec is not None:
        try:
            text = data.decode(codec)
        except UnicodeDecodeError as exc:
            raise RecordError(f"UTF-16 text with a bad character at offset {exc.start}; "
                              "save the file as UTF-8", path) from None
        notes.append("UTF-16 text")
        return text.removeprefix("\ufeff")
    if data.startswith(b"\xef\xbb\xbf"):
        data = data[3:]
    nul = data.find(b"\x00")
    if nul >= 0:
        raise RecordError(f"binary file (NUL byte at offset {nul}); a record is UTF-8 CSV text",
                          path, data.count(b"\n", 0, nul) + 1)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        bad = f"byte 0x{data[exc.start]:02x} on line {line}"
    try:
        text = data.decode("cp1252")
    except UnicodeDecodeError:
        text = data.decode("latin-1")
    notes.append(f"not UTF-8 ({bad}): read as Latin-1 (Windows-1252) text")
    return text


_SEP_LINE = re.compile(r'\s*"?sep=([,;\t|])"?[,;\t]*\s*')
_QUOTED_HEAD = re.compile(r'\s*"((?:[^"]|"")*)"(.*)', re.DOTALL)
_PADDING = re.compile(r"[\s,;\t]+$")


def spreadsheet_header(lines: list[str], notes: list[str]) -> tuple[list[str], str | None]:
    """The header lines as a spreadsheet leaves them, put back: Excel's `sep=;` first line
    (blanked, its separator returned), quoted `"# key: value"` cells unquoted and the empty
    cells padding a header line dropped. Other lines are left as they are."""
    out, delim, touched = list(lines), None, False
    for i, line in enumerate(out):
        if not line.strip():
            continue
        m = _SEP_LINE.fullmatch(line)
        if m is not None and delim is None and not touched:
            delim, out[i], touched = m.group(1), "", True
            notes.append(f"Excel's 'sep={delim}' line read as the separator")
            continue
        q = _QUOTED_HEAD.fullmatch(line)
        if q is not None and q.group(1).lstrip().startswith("#"):  # cells a spreadsheet quoted
            rest = q.group(2).lstrip(" ")
            sep = rest[0] if rest[:1] in (",", ";", "\t") else ","
            line = sep.join(next(csv.reader([line.strip(" \r\n")], delimiter=sep)))
        if not line.lstrip().startswith("#"):
            break
        out[i], touched = _PADDING.sub("", line), True
    return out, delim


def split_cells(line: str, delim: str | None, quoted: bool) -> list[str]:
    """The cells of a line: split at `delim` (blanks when None), through the csv module
    when cells are `quoted`."""
    if delim is None:
        return line.split()
    return next(csv.reader([line], delimiter=delim)) if quoted else line.split(delim)


def normalise_dialect(lines: list[str], notes: list[str], delim: str | None = None) -> list[str]:
    """The column row and data rows in the format's dialect: `,` between cells, `.` as
    decimal point, no quotes, no padding. Detected from the column row (or Excel's
    `sep=` line, `delim`): `;` or tab separated files (where a `,` in the numbers is a
    decimal comma), quoted cells and empty cells padding every row (a spreadsheet's) are
    rewritten, with a note; a plain comma-separated file is left as it is (its errors stay
    precise)."""
    head = lines[0] if lines else ""
    if delim is None:
        delim = "," if "," in head else ";" if ";" in head else "\t" if "\t" in head else ","
    sample = [ln for ln in lines[1:50] if ln.strip() and not ln.lstrip().startswith("#")]
    quoted = any('"' in ln for ln in sample) or '"' in head
    names = split_cells(head, delim, quoted)
    ncol = len(names)
    while ncol > 1 and not names[ncol - 1].strip():
        ncol -= 1
    padded = ncol < len(names)
    if delim == "," and not quoted and not padded:
        return lines
    comma = any("," in c for ln in sample for c in split_cells(ln, delim, quoted))
    out = []
    for ln in lines:
        if not (quoted or padded):  # plain ';' or tabs: text replacements, fast
            ln = ln.replace(",", ".") if comma else ln
            out.append(ln.replace(delim, ",") if delim != "," else ln)
            continue
        if not ln.strip() or ln.lstrip().startswith("#"):
            out.append(ln)
            continue
        cells = split_cells(ln, delim, quoted)
        if padded and len(cells) > ncol and not "".join(cells[ncol:]).strip():
            cells = cells[:ncol]
        if comma:
            cells = [c.replace(",", ".") for c in cells]
        out.append(",".join(cells))
    name = {";": "';'", "\t": "tabs", ",": "','", "|": "'|'"}[delim]
    notes.append(f"cells separated by {name}" + (" with decimal commas" if comma else "")
                 + (", quotes removed" if quoted else "")
                 + (", empty padding cells dropped" if padded else ""))
    return out


def text_lines(text: str, path) -> list[str]:
    if "\r" in text:  # \r\n line ends are fine; a bare \r inside a line is not
        lines = text.split("\n")
        for i, line in enumerate(lines):
            if "\r" in line.rstrip("\r"):
                raise RecordError(
                    "bare carriage return inside a line; use \\n (or \\r\\n) line ends",
                    path, i + 1)
            lines[i] = line.rstrip("\r")
        return lines
    return text.split("\n")

