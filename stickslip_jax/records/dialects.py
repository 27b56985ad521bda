"""From a file's bytes to its lines: the size limit, UTF-8 decoding, line ends, and the
cell dialects (`;` or tab separators, decimal commas, quoted cells) rewritten into the
format's own (`,` between cells, `.` as decimal point) with a note."""

from __future__ import annotations

from pathlib import Path

from .errors import RecordError


def read_bytes(path: Path, max_bytes: int) -> bytes:
    try:
        if not path.exists():
            raise RecordError("no such file; check the path", path)
        if path.is_dir():
            raise RecordError("is a directory, not a record file; give one of its record "
                              "files (fit, mcmc and discover take a directory; in Python: "
                              "read_campaign)", path)
        size = path.stat().st_size
        if size > max_bytes:
            raise RecordError(
                f"file is {size / 1e6:.1f} MB, over the {max_bytes / 1e6:.0f} MB limit; "
                "split the run into several records or decimate it",
                path,
            )
        with open(path, "rb") as fh:
            data = fh.read(max_bytes + 1)
    except OSError as exc:
        raise RecordError(f"cannot read the file: {exc.strerror or exc}", path) from None
    if len(data) > max_bytes:
        raise RecordError(f"file is over the {max_bytes / 1e6:.0f} MB limit", path)
    return data


def decode(data: bytes, path) -> str:
    if data.startswith(b"\xef\xbb\xbf"):
        data = data[3:]
    nul = data.find(b"\x00")
    if nul >= 0:
        raise RecordError(
            f"binary file (NUL byte at offset {nul}); a record is UTF-8 CSV text",
            path,
            data.count(b"\n", 0, nul) + 1,
        )
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise RecordError(
            f"not UTF-8 text (byte 0x{data[exc.start]:02x} at offset {exc.start}); "
            "save the file as UTF-8",
            path,
            data.count(b"\n", 0, exc.start) + 1,
        ) from None
    return text


def normalise_dialect(lines: list[str], notes: list[str]) -> list[str]:
    """The column row and data rows in the format's dialect: `,` between cells, `.` as
    decimal point, no quotes. Detected from the column row: `;` or tab separated files
    (where a `,` in the numbers is a decimal comma) and quoted cells are rewritten, with
    a note; a comma-separated file is left as it is (its errors stay precise)."""
    head = lines[0] if lines else ""
    delim = "," if "," in head else ";" if ";" in head else "\t" if "\t" in head else ","
    sample = [ln for ln in lines[1:50] if ln.strip() and not ln.lstrip().startswith("#")]
    quoted = any('"' in ln for ln in sample) or '"' in head
    if delim == "," and not quoted:
        return lines
    comma = delim != "," and any("," in ln for ln in sample)
    out = []
    for ln in lines:
        if quoted:
            ln = ln.replace('"', "")
        if comma:
            ln = ln.replace(",", ".")
        if delim != ",":
            ln = ln.replace(delim, ",")
        out.append(ln)
    name = {";": "';'", "\t": "tabs", ",": "','"}[delim]
    notes.append(f"cells separated by {name}" + (" with decimal commas" if comma else "")
                 + (", quotes removed" if quoted else ""))
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

