"""Design maps across processes with `jax.distributed` (2 CPU processes on localhost)
give the map of one process, bit for bit."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from ports import free_port

HERE = Path(__file__).parent


@pytest.mark.slow
def test_two_processes_give_the_one_process_map(tmp_path):
    import stickslip_jax as ss
    from stickslip_fitting.design import design_map, outer

    port = str(free_port())
    outs = [tmp_path / f"map{i}.npy" for i in range(2)]
    procs = [subprocess.Popen([sys.executable, str(HERE / "distributed_map.py"), str(i), "2",
                               port, str(outs[i])], stdout=subprocess.PIPE,
                              stderr=subprocess.STDOUT, text=True) for i in range(2)]
    logs = [p.communicate(timeout=300)[0] for p in procs]
    for p, log in zip(procs, logs):
        assert p.returncode == 0, log[-3000:]
        assert "of 2, 2 devices" in log
    w, k, v = outer(np.linspace(10, 60, 5), np.linspace(20, 130, 6),
                    np.linspace(1, 60, 7) / 60)
    m = design_map(ss.lubricant("A"), w, k, v, chunk_size=64)
    one = np.stack([np.asarray(m.amplitude), np.asarray(m.critical_speed),
                    np.asarray(m.stick_time)])
    for out in outs:  # every process ends with the whole map
        np.testing.assert_array_equal(np.load(out), one)


def test_initialize_checks_its_arguments():
    from stickslip_jax.distributed import initialize

    with pytest.raises(ValueError, match="HOST:PORT"):
        initialize("localhost", 2, 0)
    with pytest.raises(ValueError, match="process_id"):
        initialize("localhost:1234", 2, 2)
    with pytest.raises(ValueError, match="num_processes"):
        initialize("localhost:1234", 0, 0)
