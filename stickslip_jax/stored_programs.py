"""Compiled programs kept on disk and called without tracing them again.

JAX's persistent compilation cache keys a program by its lowered form, so a later
process still traces and lowers every function before it finds the compiled program:
for the features solve and the intervals' Jacobian of `stickslip fit`, about 1.5 s of
CPU time of a 4.5 s run. `stored_jit(fn)` is `eqx.filter_jit(fn)` that, once `use(folder)`
has turned the store on (the `stickslip` command does, in its compilation cache folder),
keys a call by what determines its program without tracing it: the function's name, the
arrays' shapes and dtypes, every other argument (static fields included) by its exact
text, the package's files, the libraries' versions, JAX's configuration, `XLA_FLAGS`,
the devices and the host's CPU. A stored program is loaded and called directly
(`jax.experimental.serialize_executable`); a new one is traced, compiled and stored.

A call is not stored where an argument's text does not name its value exactly (an object
printed with its address, an elided array), where the program has a host callback (an
`eqx.error_if` check) or cannot be serialised: it then runs as `eqx.filter_jit` would.
In a `jax.distributed` job (more than one process) calls run as `eqx.filter_jit`'s: a
loaded program's outputs are not placed on the process's own devices there (JAX's
persistent compilation cache still serves the compiled programs). The store is off by
default: a program is kept for the package's files as they are, so
code that patches the package at run time (tests) would store what it patched.
"""

from __future__ import annotations

import contextlib
import hashlib
import importlib.metadata
import os
import pathlib
import pickle
import platform
import sys
import tempfile
import time
import types

import equinox as eqx
import jax

__all__ = ["folder", "stored_jit", "use"]

_STATE = {"folder": None, "environment": {}, "loaded": []}

MEMORY = 16
"""Programs a process keeps loaded per stored function (the oldest are dropped: each
holds its memory maps, `stickslip_jax.programs`)."""

LIBRARIES = ("jax", "jaxlib", "equinox", "optimistix", "lineax", "numpy")


def use(path: str | os.PathLike | None) -> None:
    """Keep compiled programs in `path` (created when needed); None turns the store off.
    The programs loaded so far are dropped (the next call loads or compiles again)."""
    _STATE["folder"] = None if path is None else os.fspath(path)
    for loaded in _STATE["loaded"]:
        loaded.clear()


def folder() -> str | None:
    """The folder of the store, or None when it is off."""
    return _STATE["folder"]


class _Slot:
    """Stands for an array in the outputs' skeleton of a stored program."""


def _environment(package: str) -> str:
    """What every program of `package` (a top-level package or module) depends on besides
    its arguments (module doc)."""
    files = _STATE["environment"]
    if package not in files:
        h = hashlib.sha256()
        for name in sorted({"stickslip_jax", package}):
            module = sys.modules[name]
            root = pathlib.Path(module.__file__)
            paths = sorted(root.parent.rglob("*")) if hasattr(module, "__path__") else [root]
            for p in paths:
                if p.is_file() and "__pycache__" not in p.parts:
                    h.update(p.relative_to(root.parent).as_posix().encode() + p.read_bytes())
        versions = []
        for lib in LIBRARIES:
            try:
                versions.append(f"{lib} {importlib.metadata.version(lib)}")
            except importlib.metadata.PackageNotFoundError:
                versions.append(f"{lib} absent")
        try:  # the CPU's instruction sets: XLA compiles for the host it runs on
            with open("/proc/cpuinfo", encoding="utf-8") as fh:
                cpu = sorted({line for line in fh if line.startswith(("flags", "model name"))})
        except OSError:
            cpu = [platform.processor()]
        files[package] = repr((h.hexdigest(), versions, sys.version, platform.machine(), cpu))
    config = sorted((k, repr(v)) for k, v in jax.config.values.items()
                    if "cache" not in k and "log" not in k)
    devices = [(d.platform, d.device_kind) for d in jax.devices()]
    return repr((files[package], config, devices, os.environ.get("XLA_FLAGS")))


def _text(x, package: str) -> str:
    """An argument's text: a module-level function of `package` or of this package by
    its name (their files are in the key), anything else by `repr`."""
    if (isinstance(x, types.FunctionType) and "<" not in x.__qualname__
            and x.__module__.partition(".")[0] in ("stickslip_jax", package)):
        return f"{x.__module__}.{x.__qualname__}"
    return repr(x)


def _key(fn, options, dynamic, static) -> str | None:
    """The store's key of a call, or None where an argument has no exact text."""
    package = fn.__module__.partition(".")[0]
    leaves, tree = jax.tree_util.tree_flatten(dynamic)
    text = repr((_text(fn, package), options, str(tree),
                 str(jax.tree_util.tree_structure(static)),
                 [_text(x, package) for x in jax.tree_util.tree_leaves(static)],
                 [(x.shape, str(x.dtype), bool(getattr(x, "weak_type", False)))
                  for x in leaves]))
    if " at 0x" in text or "..." in text or "<locals>" in text:
        return None
    return hashlib.sha256((_environment(package) + text).encode()).hexdigest()


def _cache_hit(event: str, **_) -> None:
    if event == "/jax/compilation_cache/cache_hits":
        _STATE["hits"] += 1


def _compile(key, fn, options, dynamic, static):
    """(program over the flat arrays, skeleton of its outputs, whether it calls LAPACK,
    True: compiled here), or None for a program with a host callback (an `eqx.error_if`
    check: it runs as `eqx.filter_jit`'s, which reports its errors). The program is
    named after its key, so JAX's persistent cache holds it only when it was compiled for
    the store before; a program that cache gives back cannot be stored (serialised again
    it no longer loads: "Function ... not found"), so it is compiled again under a name
    of its own."""
    if "hits" not in _STATE:
        _STATE["hits"] = 0
        jax.monitoring.register_event_listener(_cache_hit)
    leaves, tree = jax.tree_util.tree_flatten(dynamic)
    out_skeleton = []

    def flat(*xs):
        out = fn(*eqx.combine(jax.tree_util.tree_unflatten(tree, xs), static))
        out_skeleton.append(jax.tree_util.tree_map(
            lambda x: _Slot() if eqx.is_array(x) else x, out))
        return jax.tree_util.tree_leaves(eqx.filter(out, eqx.is_array))

    for name in (key[:16], f"{key[:16]}_{os.getpid()}_{time.time_ns()}"):
        flat.__name__ = flat.__qualname__ = f"stored_{name}"
        lowered = jax.jit(flat, compiler_options=options).lower(*leaves)
        text = lowered.as_text()
        if "callback" in text:
            return None
        hits = _STATE["hits"]
        program = lowered.compile()
        if hits == _STATE["hits"]:  # compiled here
            break
    return program, out_skeleton[0], "lapack_" in text, True


def _load(path):
    """(program, skeleton, lapack, False) stored at `path`, or None."""
    from jax.experimental.serialize_executable import deserialize_and_load

    try:
        with open(path, "rb") as fh:
            payload, n_in, n_out, skeleton, lapack = pickle.load(fh)
        if lapack:  # lowering sets up the LAPACK kernels a program calls; else this does
            import numpy as np

            jax.jit(jax.numpy.linalg.eigh).lower(np.eye(2))
        program = deserialize_and_load(
            payload, jax.tree_util.tree_structure(((0,) * n_in, {})),
            jax.tree_util.tree_structure([0] * n_out))
    except (OSError, EOFError, pickle.UnpicklingError, AttributeError, ImportError, ValueError,
            TypeError, jax.errors.JaxRuntimeError):
        return None
    return program, skeleton, lapack, False


def _save(path, program, n_in, skeleton, lapack) -> None:
    """Write `program` to `path` atomically; a program or folder that cannot take it is
    not stored."""
    from jax.experimental.serialize_executable import serialize

    try:
        payload, _, out_tree = serialize(program)
        blob = pickle.dumps((payload, n_in, out_tree.num_leaves, skeleton, lapack))
        os.makedirs(os.path.dirname(path), exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=os.path.dirname(path))
        with os.fdopen(fd, "wb") as fh:
            fh.write(blob)
        os.replace(tmp, path)
    except (OSError, ValueError, NotImplementedError, TypeError, AttributeError,
            pickle.PicklingError):
        return


def stored_jit(fn=None, *, compiler_options: dict | None = None):
    """`eqx.filter_jit(fn, compiler_options=...)` whose programs, with the store on
    (`use`), are kept on disk and called without tracing (module doc). Usable as a
    decorator with or without its options. A stored program that fails to run is
    removed and the call runs as `eqx.filter_jit`'s."""
    if fn is None:
        return lambda f: stored_jit(f, compiler_options=compiler_options)
    jitted = eqx.filter_jit(fn, compiler_options=compiler_options)
    loaded: dict[str, tuple] = {}
    _STATE["loaded"].append(loaded)

    def call(*args):
        where = _STATE["folder"]
        dynamic, static = eqx.partition(args, eqx.is_array)
        # In a `jax.distributed` job a loaded program's outputs are not placed on the
        # process's own devices (a later operation on them fails): calls there are traced.
        off = where is None or jax.process_count() > 1
        key = None if off else _key(fn, compiler_options, dynamic, static)
        if key is None:
            return jitted(*args)
        path = os.path.join(where, key)
        if key not in loaded:
            found = _load(path) if os.path.exists(path) else None
            if found is None:
                found = _compile(key, fn, compiler_options, dynamic, static)
                if found is not None:
                    _save(path, found[0], len(jax.tree_util.tree_leaves(dynamic)), *found[1:3])
            while len(loaded) >= MEMORY:
                loaded.pop(next(iter(loaded)))
            loaded[key] = found
        if loaded[key] is None:
            return jitted(*args)
        program, skeleton, _, fresh = loaded[key]
        try:
            out = iter(jax.block_until_ready(program(*jax.tree_util.tree_leaves(dynamic))))
        except jax.errors.JaxRuntimeError:
            if fresh:
                raise
            loaded.pop(key, None)
            with contextlib.suppress(OSError):
                os.remove(path)
            return jitted(*args)
        return jax.tree_util.tree_map(lambda x: next(out) if isinstance(x, _Slot) else x,
                                      skeleton)

    call.__wrapped__ = fn
    call.__doc__ = fn.__doc__
    return call
