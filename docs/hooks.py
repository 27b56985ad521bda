"""mkdocs hooks: the paper-to-code map page is generated from the code at every build
(`docs/paper_map.py`), so it cannot fall out of date."""

from __future__ import annotations

import importlib.util
import pathlib

from mkdocs.structure.files import File

_HERE = pathlib.Path(__file__).resolve().parent


def _paper_map():
    spec = importlib.util.spec_from_file_location("stickslip_paper_map", _HERE / "paper_map.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def on_files(files, config):
    files.append(File.generated(config, "paper-map.md", content=_paper_map().markdown()))
    return files
