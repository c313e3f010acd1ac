"""pyarrow and PyAV, which only datasets need: imported on first use, and a clear error
naming the extra that installs them when they are missing."""

from __future__ import annotations

import importlib
import importlib.util
from types import ModuleType

from armtree.errors import ConfigError

#: What installs the dataset's dependencies.
INSTALL = "pip install 'armtree[dataset]'"


def require(where: str) -> None:
    """Raise a :class:`ConfigError` at ``where`` unless pyarrow and PyAV are installed
    (found, not imported: a run that only records never loads pyarrow)."""
    missing = []
    for name in ("pyarrow", "av"):
        if importlib.util.find_spec(name) is None:
            missing.append("PyAV (av)" if name == "av" else name)
    if missing:
        raise ConfigError(
            f"datasets need {' and '.join(missing)}, which this install lacks: {INSTALL}",
            file=where,
        )


def pyarrow() -> tuple[ModuleType, ModuleType]:
    """``(pyarrow, pyarrow.parquet)``."""
    try:
        return importlib.import_module("pyarrow"), importlib.import_module("pyarrow.parquet")
    except ImportError:
        require("dataset")
        raise


def av() -> ModuleType:
    """PyAV."""
    try:
        return importlib.import_module("av")
    except ImportError:
        require("dataset")
        raise
