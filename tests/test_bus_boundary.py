"""Only robodcn.bus knows the control table (issue 27 §5). import-linter's forbidden
contract keeps the stream and the workflows from importing ``robodcn.bus.control_table``;
this keeps them from reaching the same addresses through ``robodcn.bus``'s re-exports, or
packing item bytes themselves, where import-linter cannot see: they call named bus methods.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1] / "robodcn"
#: The layers above the bus that stream or administer servos.
CLIENTS = sorted([*(ROOT / "stream").rglob("*.py"), *(ROOT / "workflow").rglob("*.py"),
                  ROOT / "controller.py", ROOT / "servo_admin.py"])


def leaks(path: Path) -> list[str]:
    """Control-table addresses imported and byte codecs called in ``path`` (line: what)."""
    out = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("robodcn.bus"):
            out += [f"{node.lineno}: imports {a.name}" for a in node.names
                    if a.name.startswith("ADDR_")]
        elif isinstance(node, ast.Attribute) and node.attr in ("to_bytes", "from_bytes"):
            out.append(f"{node.lineno}: calls .{node.attr}")
        elif isinstance(node, ast.Assign):
            out += [f"{node.lineno}: defines {t.id}" for t in node.targets
                    if isinstance(t, ast.Name) and t.id.startswith("ADDR_")]
    return out


def test_the_clients_exist() -> None:
    assert len(CLIENTS) > 10 and all(p.is_file() for p in CLIENTS)


@pytest.mark.parametrize("path", CLIENTS, ids=lambda p: str(p.relative_to(ROOT)))
def test_no_address_or_byte_codec_above_the_bus(path: Path) -> None:
    assert leaks(path) == [], f"{path.relative_to(ROOT)}: add a named bus method instead"


def test_the_check_sees_a_leak(tmp_path: Path) -> None:
    bad = tmp_path / "bad.py"
    bad.write_text("from robodcn.bus import ADDR_GOAL_POSITION, ServoBus\n"
                   "ADDR_ID = 7\n"
                   "x = int.from_bytes(b'\\x01\\x00', 'little')\n")
    assert leaks(bad) == ["1: imports ADDR_GOAL_POSITION", "2: defines ADDR_ID",
                          "3: calls .from_bytes"]
