"""The package's architecture as a contract (docs/architecture.md).

* the layers: each package imports only from the layers below it, so nothing below ``cli``
  imports ``cli`` (import-linter, ``[tool.importlinter]`` in pyproject.toml);
* no import cycle between the modules of any package (import-linter's ``acyclic_siblings`` on
  every package), nor through a package's ``__init__`` (a module importing a name its own
  package re-exports);
* one concern per module: no module past :data:`MAX_LINES` lines.

Imports inside functions count: a lazy import hides a cycle from Python, not from a reader.
"""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "gyrotest"
#: "a module past ~800 lines usually holds two" (the developers' brief)
MAX_LINES = 850


def _modules() -> dict[str, tuple[Path, bool]]:
    out = {}
    for p in PACKAGE.rglob("*.py"):
        parts = list(p.relative_to(ROOT).with_suffix("").parts)
        is_pkg = parts[-1] == "__init__"
        out[".".join(parts[:-1] if is_pkg else parts)] = (p, is_pkg)
    return out


def test_import_contracts_are_kept():
    """The layers and the acyclic contract of pyproject.toml (import-linter)."""
    run = subprocess.run(
        [sys.executable, "-c", "from importlinter.cli import lint_imports_command as c; c()",
         "--config", str(ROOT / "pyproject.toml"), "--no-cache", "--no-logo"],
        capture_output=True, text=True, cwd=ROOT, timeout=300)
    assert run.returncode == 0, run.stdout + run.stderr
    assert "Contracts: 2 kept, 0 broken." in run.stdout, run.stdout


def test_no_module_imports_from_its_own_package_init():
    """``from . import name`` in ``pkg/mod.py`` where ``name`` lives in ``pkg/__init__.py``
    (not a submodule) is a cycle through the package's ``__init__``; the one exception is
    ``gyrotest.__version__``, which the root package defines before importing anything."""
    mods = _modules()
    bad = []
    for name, (path, is_pkg) in mods.items():
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if not isinstance(node, ast.ImportFrom):
                continue
            if node.level:
                base = name.split(".") if is_pkg else name.split(".")[:-1]
                base = base[:len(base) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if target not in mods or not mods[target][1] or not name.startswith(target + "."):
                continue
            names = [a.name for a in node.names if f"{target}.{a.name}" not in mods
                     and (target, a.name) != ("gyrotest", "__version__")]
            if names:
                bad.append(f"{path.relative_to(ROOT)}:{node.lineno}: {names} from {target}")
    assert not bad, "\n".join(bad)


def test_no_module_is_oversized():
    """One concern per module: a module past MAX_LINES lines is split by concern."""
    big = {str(p.relative_to(ROOT)): n for p, _ in _modules().values()
           if (n := len(p.read_text(encoding="utf-8").splitlines())) > MAX_LINES}
    assert not big, big
