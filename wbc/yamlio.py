"""Reading YAML files: ``yaml.safe_load`` only, a mapping at the top, errors that name the file."""

from __future__ import annotations

from pathlib import Path

import yaml

from .errors import ConfigError, WbcError


def read_mapping(path: str | Path, error: type[WbcError] = ConfigError) -> dict:
    path = Path(path)
    if not path.is_file():
        raise error(f"{path}: file not found")
    try:
        data = yaml.safe_load(path.read_text())
    except yaml.YAMLError as exc:
        raise error(f"{path}: not valid YAML: {exc}") from exc
    if not isinstance(data, dict):
        raise error(f"{path}: expected a mapping at the top level")
    return data
