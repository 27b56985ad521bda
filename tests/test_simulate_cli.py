"""`stickslip simulate`: writes a readable record with its truth; errors are one line."""

import numpy as np

from stickslip_jax.cli import main
from stickslip_jax.records import read_record


def test_simulate_writes_a_record_with_truth(tmp_path, capsys):
    out = tmp_path / "run.csv"
    rc = main(["simulate", "--lubricant", "A", "--weight", "36", "--stiffness", "86.9",
               "--speed", "3", "--duration", "5", "--sample-rate", "200", "--noise", "0.5um",
               "--seed", "1", "--out", str(out)])
    assert rc == 0
    rec = read_record(out)
    assert rec.time.size == 1001
    assert rec.truth["noise_mm"] == 5e-4 and rec.truth["seed"] == 1
    assert rec.truth["simulator"]["name"] == "exact"
    assert rec.truth["friction"]["static"]["mu_s"] == 0.56
    np.testing.assert_allclose(rec.drive_speed, 3.0 / 60)
    # noise of the requested size: residual against a noiseless run
    rc = main(["simulate", "--weight", "36", "--stiffness", "86.9", "--speed", "3",
               "--duration", "5", "--sample-rate", "200", "--out", str(tmp_path / "c.csv")])
    clean = read_record(tmp_path / "c.csv")
    assert abs(np.std(rec.deflection - clean.deflection) / 5e-4 - 1) < 0.1


def test_drive_program_and_user_errors(tmp_path, capsys):
    out = tmp_path / "shs.csv"
    rc = main(["simulate", "--weight", "36", "--stiffness", "86.9", "--drive-program",
               "0 s 3 mm/min; 2 s 0 mm/min; 3 s 3 mm/min", "--duration", "4",
               "--sample-rate", "100", "--out", str(out)])
    assert rc == 0
    assert read_record(out).drive_program is not None
    rc = main(["simulate", "--weight", "36", "--stiffness", "86.9", "--duration", "4",
               "--out", str(out)])
    assert rc == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--speed" in err[0]
