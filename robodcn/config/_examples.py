"""The example arms shipped as package data, and what an arm name or path names.

``robodcn/config/data/arm3r.toml``, ``arm2r.toml`` and ``omx.toml`` are copies of
``configs/`` (a test keeps them identical), so ``--arm omx`` and ``robodcn.load_arm("omx")``
work from any directory and after a wheel install, where ``configs/`` does not exist.
"""

from __future__ import annotations

import os
from importlib import resources
from pathlib import Path

from robodcn.errors import InputError

#: Example arm names → one-line description.
EXAMPLES: dict[str, str] = {
    "arm3r": "3 joints (shoulder, elbow, wrist), XM430-W350: full poses x, y, θ",
    "arm2r": "2 joints (shoulder, elbow), XL430-W250: positions x, y (θ free)",
    "omx": "OpenMANIPULATOR-X: base yaw + 3 joints in a vertical plane, XM430-W350 ids 11–15, "
           "gripper: poses x, y, z, pitch",
}
#: Used when neither --arm nor $ROBODCN_ARM is given.
DEFAULT_EXAMPLE = "arm3r"


def example_path(name: str) -> Path:
    """Path of the packaged example ``name`` (``"arm3r"``, ``"arm2r"`` or ``"omx"``)."""
    if name not in EXAMPLES:
        raise InputError(f"unknown example arm {name!r} (examples: {', '.join(EXAMPLES)})",
                         field="example", value=name)
    return Path(str(resources.files("robodcn.config") / "data" / f"{name}.toml"))


def example_text(name: str) -> str:
    """The TOML text of the packaged example ``name``, comments included."""
    return example_path(name).read_text(encoding="utf-8")


def arm_path(name_or_path: str | os.PathLike[str]) -> Path:
    """The file an arm name or path names: an existing file, else the packaged example of
    that name, else the path as given (reading it then says it is missing)."""
    path = Path(name_or_path)
    if not path.is_file() and str(name_or_path) in EXAMPLES:
        return example_path(str(name_or_path))
    return path


def resolve_arm_path(name_or_path: str | os.PathLike[str] | None, *,
                     option: str = "--arm") -> Path:
    """The file an ``--arm`` value names: an existing file, else a packaged example name.

    None means ``$ROBODCN_ARM``, else ``configs/arm3r.toml`` in the working directory when it
    exists, else the packaged arm3r example. InputError naming ``option`` otherwise.
    """
    if name_or_path is None or str(name_or_path) == "":
        env = os.environ.get("ROBODCN_ARM")
        if env:
            return resolve_arm_path(env, option="$ROBODCN_ARM")
        local = Path("configs") / f"{DEFAULT_EXAMPLE}.toml"
        return local if local.is_file() else example_path(DEFAULT_EXAMPLE)
    path = arm_path(name_or_path)
    if path.is_file():
        return path
    raise InputError(f"{option}: {str(name_or_path)!r} is neither a file nor an example arm "
                     f"({', '.join(EXAMPLES)})", field=option.lstrip("-$").lower(),
                     value=str(name_or_path))


__all__ = ["DEFAULT_EXAMPLE", "EXAMPLES", "arm_path", "example_path", "example_text",
           "resolve_arm_path"]
