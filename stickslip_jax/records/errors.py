"""The one error type of reading and building records."""

from __future__ import annotations


class RecordError(ValueError):
    """A record that cannot be read or built; the message names the file, line and fix.

    Attributes: `path` (file or None), `line` (1-based line number or None),
    `reason` (the message without the location), and where a `Record` refused a value,
    `field` (the field's name, an extra header's key) and `index` (the sample), which
    the file reader turns into the line.
    """

    def __init__(self, reason: str, path=None, line: int | None = None, *,
                 field: str | None = None, index: int | None = None):
        self.path = None if path is None else str(path)
        self.line = line
        self.reason = reason
        self.field = field
        self.index = index
        where = ""
        if self.path is not None:
            where = f"{self.path}: " if line is None else f"{self.path}: line {line}: "
        elif line is not None:
            where = f"line {line}: "
        super().__init__(where + reason)
