"""What every one-call result writes (`CampaignFit`, `CampaignPosterior`, `DesignStudy`):
its command's JSON document (`to_json`, `to_dict`), files that never overwrite one of the
inputs it read (`output_path`), and pandas for `summary()` (`pandas_module`)."""

from __future__ import annotations

import os
from typing import ClassVar

from stickslip_jax.records.dataframe import pandas_module

__all__ = ["ResultDocument", "pandas_module"]


class ResultDocument:
    """A result with `report` (its command's `--json` document before versioning) and
    `inputs` (the files read). `JSON_ALIASES`: the document's renamed keys (old names
    written beside them for one release); `JSON_INDENT`: None for one line."""

    JSON_ALIASES: ClassVar[dict[str, str] | None] = None
    JSON_INDENT: ClassVar[int | None] = 2

    def output_path(self, path, what: str) -> str | None:
        """`path` as a string, once checked (a writable place, not one of the inputs)."""
        if path is None:
            return None
        from stickslip_jax.output import check_outputs

        check_outputs({what: os.fspath(path)}, self.inputs)
        return os.fspath(path)

    def to_json(self, path: str | os.PathLike[str] | None = None) -> str:
        """The command's `--json` document (with "schema_version" and the deprecated keys
        it carries) as text; written to `path` too when given (atomically; never over one
        of the inputs)."""
        from stickslip_jax.output import dumps, versioned, write_text

        text = dumps(versioned(self.report, self.JSON_ALIASES), indent=self.JSON_INDENT) + "\n"
        path = self.output_path(path, "to_json")
        if path is not None:
            write_text(path, text)
        return text

    def to_dict(self) -> dict:
        """The `--json` document as a dict (strict JSON: NaN as None)."""
        import json

        return json.loads(self.to_json())
