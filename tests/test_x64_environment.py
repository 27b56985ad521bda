"""Importing stickslip_jax turns on float64 in this process only: JAX gets the flag
(`jax.config`), the environment that child processes inherit is left as it was."""

import json
import os
import subprocess
import sys

import pytest

_CHILD = "import json, os, jax.numpy as jnp; print(json.dumps([os.environ.get('JAX_ENABLE_X64'), str(jnp.zeros(1).dtype)]))"

_PARENT = f"""
import json, os, subprocess, sys
JAX_FIRST = JAX_FIRST_VALUE
if JAX_FIRST:
    import jax
import stickslip_jax
before_jax = os.environ.get("JAX_ENABLE_X64")
import jax, jax.numpy as jnp
child = subprocess.run([sys.executable, "-c", {_CHILD!r}], capture_output=True, text=True,
                       check=True)
print(json.dumps({{
    "env_before_jax": before_jax,
    "env_after_jax": os.environ.get("JAX_ENABLE_X64"),
    "x64": bool(jax.config.jax_enable_x64),
    "dtype": str(jnp.zeros(1).dtype),
    "hooks_left": [type(f).__name__ for f in sys.meta_path if "X64" in type(f).__name__],
    "child": json.loads(child.stdout),
}}))
"""


def _run(jax_first: bool, env: dict) -> dict:
    run = subprocess.run([sys.executable, "-c", _PARENT.replace("JAX_FIRST_VALUE", str(jax_first))],
                         capture_output=True, text=True, timeout=180, env=env)
    assert run.returncode == 0, run.stderr[-3000:]
    return json.loads(run.stdout.strip().splitlines()[-1])


def _env_without_x64() -> dict:
    return {k: v for k, v in os.environ.items() if k != "JAX_ENABLE_X64"}


@pytest.mark.parametrize("jax_first", [False, True])
def test_x64_for_the_process_not_for_its_children(jax_first):
    doc = _run(jax_first, _env_without_x64())
    assert doc["x64"] is True and doc["dtype"] == "float64", doc
    assert doc["env_before_jax"] is None and doc["env_after_jax"] is None, doc
    assert doc["hooks_left"] == [], doc  # the import hook is gone once JAX is imported
    # a process started afterwards sees no variable and keeps JAX's default precision
    assert doc["child"] == [None, "float32"], doc


def test_a_variable_the_user_set_is_kept():
    env = dict(_env_without_x64(), JAX_ENABLE_X64="0")
    doc = _run(False, env)
    # the package's float64 wins in its own process; the user's setting reaches children
    assert doc["x64"] is True and doc["dtype"] == "float64", doc
    assert doc["env_after_jax"] == "0" and doc["child"] == ["0", "float32"], doc
