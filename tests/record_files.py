"""Shared by the command-line tests: records written as files a command reads."""

import dataclasses

from stickslip_jax.records import write_record

SMALL_CAMPAIGN = dict(runs=((36.0, 86.9), (20.0, 27.3)), speeds=(5.0, 10.0), cycles=5.0)
"""A small campaign of the independent generator (`independent_records.campaign`): two
(W kgf, k kgf/mm) at 5 and 10 mm/min, about 5 cycles each."""


def record_files(records, folder) -> list[str]:
    """Write each record to `folder`/<its name>.csv and return the paths, in order."""
    return [str(write_record(r, folder / f"{r.name}.csv")) for r in records]


def clean_discovery_files(folder) -> list[str]:
    """`stickslip discover`'s input in test_cycle_discovery and test_json_keys: the clean
    `SMALL_CAMPAIGN` (seed 11) as files r0-r3.csv, one irregular record and one file that
    is not a record. Both modules read one run of `discover FILES --json OUT --learn` on
    it (conftest `clean_discovery`)."""
    import independent_records as ir

    paths = []
    for i, r in enumerate(ir.campaign(seed=11, **SMALL_CAMPAIGN)):
        paths.append(str(write_record(r, folder / f"r{i}.csv")))
    # one irregular record (mu_s drawn per cycle, 5 % spread): the paper's model
    # describes it at chi2/n ~500 (measured); it must be set aside and listed, not bend
    # the others' base fit (before, the campaign's median chi2/n rose to 107 and the
    # screw error was named on the clean records)
    bad = ir.campaign(seed=12, imp=ir.Imperfections(mu_s_jitter=0.05),
                      runs=((20.0, 27.3),), speeds=(5.0,), cycles=5.0)[0]
    paths.append(str(write_record(dataclasses.replace(bad, note="irregular"),
                                  folder / "irregular.csv")))
    # and a file that is not a record (a summary table left among the records): listed
    # as unreadable, the campaign goes on (it stopped the whole campaign before)
    summary = folder / "summary.csv"
    summary.write_text("run,speed,amplitude\n1,5,0.02\n")
    paths.append(str(summary))
    return paths
