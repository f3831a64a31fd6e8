"""The scenarios bundled with the package (``wbc/data/scenarios/*.yaml``).

They ship inside the wheel, so ``wbc run talos_balance`` works from any directory of any
install; ``wbc examples DIR`` copies them out as starting points for a user's own.
"""

from __future__ import annotations

import shutil
from pathlib import Path

from wbc.errors import ConfigError
from wbc.validation.schema import is_file, show

#: the bundled scenario YAMLs, inside the package
SCENARIOS_DIR = Path(__file__).resolve().parents[1] / "data" / "scenarios"


def available_scenarios() -> list[str]:
    """Names of the bundled scenarios (``talos_balance``, ...)."""
    return sorted(p.stem for p in SCENARIOS_DIR.glob("*.yaml"))


def scenario_path(name_or_path: str | Path) -> Path:
    """A scenario file: a path to a YAML as given, or a bundled scenario's name.

    A name without ``.yaml``/``.yml`` that is not an existing file is looked up among the
    bundled scenarios; an unknown one raises :class:`ConfigError` naming the choices."""
    p = Path(name_or_path)
    if p.suffix in (".yaml", ".yml") or is_file(p):
        return p
    candidate = SCENARIOS_DIR / f"{p.name}.yaml"
    if p.parent == Path(".") and is_file(candidate):
        return candidate
    raise ConfigError(f"{show(str(name_or_path))[1:-1]}: no such scenario file; bundled scenarios: "
                      f"{', '.join(available_scenarios())}")


def copy_examples(dest: str | Path, overwrite: bool = False) -> list[Path]:
    """Copy the bundled scenarios into ``dest`` (created if missing); returns the files
    written. An existing file is kept unless ``overwrite``."""
    out = Path(dest)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for src in sorted(SCENARIOS_DIR.glob("*.yaml")):
        target = out / src.name
        if target.exists() and not overwrite:
            continue
        shutil.copyfile(src, target)
        written.append(target)
    return written
