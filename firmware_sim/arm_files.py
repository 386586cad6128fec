"""Finding an arm file by name (``--arm omx``) without importing robodcn.

A name (no directory part, no ``.toml``) is looked up, in order, as
``configs/<name>.toml`` of the checkout firmware_sim sits in, then as the packaged copy
``robodcn/config/data/<name>.toml`` beside the firmware_sim package directory. Both are
found by path: firmware_sim never imports robodcn.
"""

from __future__ import annotations

import os
from pathlib import Path

#: The directory holding the firmware_sim package (the checkout's root, or site-packages).
_BESIDE = Path(__file__).resolve().parent.parent
#: Where names are looked up, in order.
SEARCH_DIRS = (_BESIDE / "configs", _BESIDE / "robodcn" / "config" / "data")


def is_name(source: str | os.PathLike[str]) -> bool:
    """Whether ``source`` is an arm name rather than a path (no directory, no suffix)."""
    text = os.fspath(source)
    return bool(text) and os.sep not in text and "/" not in text and not text.endswith(".toml")


def find_arm(name: str) -> Path | None:
    """The arm file called ``name`` (module notes), or None."""
    for directory in SEARCH_DIRS:
        candidate = directory / f"{name}.toml"
        if candidate.is_file():
            return candidate
    return None


def known_arms() -> list[str]:
    """Every arm name :func:`find_arm` can find."""
    return sorted({p.stem for d in SEARCH_DIRS if d.is_dir() for p in d.glob("*.toml")})
