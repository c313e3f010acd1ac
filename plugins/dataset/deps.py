"""pyarrow and PyAV, which only datasets need: imported on first use, and a clear error
naming the extra that installs them when they are missing."""

from __future__ import annotations

import importlib
from types import ModuleType

from armtree.errors import ConfigError

#: What installs the dataset's dependencies.
INSTALL = "pip install 'armtree[dataset]'"


def require(where: str) -> None:
    """Raise a :class:`ConfigError` at ``where`` unless pyarrow and PyAV import."""
    missing = []
    for name in ("pyarrow", "av"):
        try:
            importlib.import_module(name)
        except ImportError:
            missing.append("PyAV (av)" if name == "av" else name)
    if missing:
        raise ConfigError(
            f"datasets need {' and '.join(missing)}, which this install lacks: {INSTALL}",
            file=where,
        )


def pyarrow() -> tuple[ModuleType, ModuleType]:
    """``(pyarrow, pyarrow.parquet)``."""
    require("dataset")
    return importlib.import_module("pyarrow"), importlib.import_module("pyarrow.parquet")


def av() -> ModuleType:
    """PyAV."""
    require("dataset")
    return importlib.import_module("av")
