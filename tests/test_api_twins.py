"""Every shell example of the manual's "Python twins" page gives the same numbers as its
Python twin: the command's ``--json`` document against the twin's ``res.to_dict()`` (or the
dict it builds), number by number.

The page (docs/twins.md) holds the README's shell examples, each followed by its Python
block; both run in a scratch directory whose ``sample_data`` is the repository's.
"""

from __future__ import annotations

import json
import math
import re
import shlex
from pathlib import Path

import pytest

from cliutil import run_cli

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "twins.md"
README = ROOT / "README.md"

#: keys that name files written or time the run: not results
SKIP_KEYS = {"files", "written", "model_file", "plot", "points_file", "output", "provenance",
             "timing_s", "simulate_s", "write_s", "csv", "psd"}


def _pairs() -> list[tuple[str, str]]:
    text = PAGE.read_text(encoding="utf-8")
    return re.findall(r"```sh\n(gyrotest [^\n]+)\n```\s*\n```python\n(.*?)```", text, re.S)


PAIRS = _pairs()


def _compare(cli, py, path: str, counted: list[int]) -> None:
    """Every number and flag both documents hold at the same place is equal (strings such as
    the source name may differ: '<stdin>' against '<DataFrame>')."""
    if isinstance(cli, dict) and isinstance(py, dict):
        for k in cli.keys() & py.keys():
            if k not in SKIP_KEYS:
                _compare(cli[k], py[k], f"{path}.{k}", counted)
    elif isinstance(cli, list) and isinstance(py, list):
        assert len(cli) == len(py), f"{path}: {len(cli)} vs {len(py)} items"
        for i, (a, b) in enumerate(zip(cli, py)):
            _compare(a, b, f"{path}[{i}]", counted)
    elif isinstance(cli, bool) or isinstance(py, bool):
        assert cli == py, f"{path}: {cli} vs {py}"
    elif isinstance(cli, (int, float)) and isinstance(py, (int, float)):
        assert math.isclose(cli, py, rel_tol=1e-9, abs_tol=1e-12), f"{path}: {cli} vs {py}"
        counted[0] += 1
    elif cli is None or py is None:
        assert cli is None and py is None, f"{path}: {cli!r} vs {py!r}"


@pytest.fixture(scope="module")
def scratch(tmp_path_factory):
    d = tmp_path_factory.mktemp("twins")
    (d / "sample_data").symlink_to(ROOT / "sample_data")
    return d


def test_the_page_pairs_every_analysis_command_of_the_readme():
    assert len(PAIRS) >= 12, PAIRS
    readme = README.read_text(encoding="utf-8")
    shown = {shlex.split(cmd)[1] for cmd, _ in PAIRS}
    for name in ("info", "bias", "allan", "scale-factor", "model", "thermal-fit", "mag-fit",
                 "report", "simulate"):
        assert f"gyrotest {name}" in readme and name in shown, name


@pytest.mark.parametrize("cmd,code", PAIRS, ids=[c.split()[1] + f"-{i}" for i, (c, _) in
                                                  enumerate(PAIRS)])
def test_python_twin_gives_the_commands_numbers(cmd, code, scratch, monkeypatch):
    monkeypatch.chdir(scratch)
    args = shlex.split(cmd)[1:]
    r = run_cli([*args, "--json", "-q"])
    assert r.code == 0, r.err
    cli = json.loads(r.out)
    import gyrotest

    ns: dict = {"gyrotest": gyrotest}
    exec(compile(code, f"<twin of {cmd}>", "exec"), ns)
    res = ns["res"]
    from gyrotest.core.output import dumps

    py = json.loads(dumps(res.to_dict() if hasattr(res, "to_dict") else res))
    counted = [0]
    _compare(cli, py, args[0], counted)
    assert counted[0] >= 5, f"only {counted[0]} numbers compared"

