"""Shared by the command-line tests: records written as files a command reads."""

from stickslip_jax.records import write_record


def record_files(records, folder) -> list[str]:
    """Write each record to `folder`/<its name>.csv and return the paths, in order."""
    return [str(write_record(r, folder / f"{r.name}.csv")) for r in records]
