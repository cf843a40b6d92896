"""The public Python API: its surface (listed, in the CHANGELOG), its docstrings (numpydoc
sections, examples that run), its result objects, its errors, and that ``import gyrotest``
stays cheap."""

from __future__ import annotations

import doctest
import importlib
import inspect
import pydoc
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import gyrotest

ROOT = Path(__file__).resolve().parents[1]
SURFACE = Path(__file__).resolve().parent / "data" / "api_surface.txt"
FUNCTIONS = ["read", "allan", "bias", "scale_factor", "thermal_fit", "mag_fit", "compensate",
             "report", "simulate"]


def _function(name: str):
    """The API function behind a public name."""
    return getattr(gyrotest, name)


def surface() -> str:
    """One line per public name: functions with their signature, classes with their public
    methods and properties."""
    lines = []
    for name in sorted(n for n in gyrotest.__all__ if n != "__version__"):
        obj = _function(name) if name in FUNCTIONS else getattr(gyrotest, name)
        if inspect.isclass(obj):
            members = sorted(m for m, v in vars(obj).items() if not m.startswith("_")
                             and (callable(v) or isinstance(v, (property, classmethod))))
            lines.append(f"class {name}: {', '.join(members)}")
        else:
            sig = str(inspect.signature(obj)).replace("'", '"')
            sig = re.sub(r" -> .*$", "", sig)
            lines.append(f"def {name}{sig}")
    return "\n".join(lines) + "\n"


def test_public_surface_is_recorded():
    """A change of the public API (a name, a parameter, a method) fails here until the
    snapshot is updated (python tests/test_api.py --update) and CHANGELOG.md says so."""
    assert SURFACE.read_text(encoding="utf-8") == surface(), (
        "the public API changed: add a line to CHANGELOG.md ([Unreleased]) naming the change, "
        "then update tests/data/api_surface.txt with 'python tests/test_api.py --update'")


def test_every_public_name_is_in_the_changelog():
    log = (ROOT / "CHANGELOG.md").read_text(encoding="utf-8")
    missing = [n for n in gyrotest.__all__ if n != "__version__" and f"gyrotest.{n}" not in log]
    assert not missing, f"CHANGELOG.md does not name {missing}"


def test_all_lists_loadable_names():
    for name in gyrotest.__all__:
        assert getattr(gyrotest, name) is not None
    with pytest.raises(AttributeError):
        gyrotest.no_such_name  # noqa: B018


def test_import_gyrotest_loads_no_numpy_or_pandas():
    code = ("import sys, gyrotest; gyrotest.__all__; "
            "print(sorted(m for m in ('numpy', 'pandas', 'scipy', 'matplotlib') "
            "if m in sys.modules))")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert r.stdout.strip() == "[]", r.stdout


@pytest.mark.parametrize("name", FUNCTIONS + ["Model"])
def test_numpydoc_sections_and_every_parameter(name):
    obj = _function(name) if name in FUNCTIONS else getattr(gyrotest, name)
    doc = inspect.getdoc(obj)
    for section in ("Parameters\n----------", "Raises\n------", "Examples\n--------", ">>> "):
        assert section in doc, (name, section)
    if name != "Model":
        assert "Returns\n-------" in doc, name
    params = doc.split("Parameters\n----------", 1)[1].split("\n\n", 1)[0]
    block = doc.split("Parameters\n----------", 1)[1].split("Returns\n-------")[0]
    for p in inspect.signature(obj).parameters.values():
        key = ("**" if p.kind is p.VAR_KEYWORD else "") + p.name
        assert re.search(rf"(^|[ ,]){re.escape(key)}\b", block, re.M), (name, key, params)
    assert re.search(r"IEEE\s+Std\s+952|Antonova|Krobka|NIST", doc), (name, "no source cited")


def test_help_allan_is_the_complete_docstring():
    text = pydoc.render_doc(gyrotest.allan, renderer=pydoc.plaintext)
    for part in ("Parameters", "Returns", "Raises", "Examples", "Annex C",
                 "sigma^2(\\tau)", ">>> res = gyrotest.allan(sim"):
        assert part in text, part


@pytest.mark.parametrize("module", ["gyrotest.api.analyses", "gyrotest.api.models",
                                    "gyrotest.api.campaign"])
def test_docstring_examples_run(module, monkeypatch):
    monkeypatch.chdir(ROOT)  # the examples use sample_data/
    mod = importlib.import_module(module)
    res = doctest.testmod(mod, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert res.failed == 0 and res.attempted > 0, res


@pytest.fixture(scope="module")
def sim():
    return gyrotest.simulate({"record": {"sample_rate_hz": 10, "duration_s": "1h"},
                              "gyro": {"bias_dph": 0.5, "noise": {"N": 0.01, "B": 0.01}},
                              "site": {"latitude_deg": 48.0, "ia": "up"}}, seed=7)


def test_results_have_the_four_methods(sim):
    import matplotlib.pyplot as plt

    results = [gyrotest.allan(sim, terms="N,B", diagnose=False), gyrotest.bias(sim), sim,
               gyrotest.thermal_fit(setpoints=ROOT / "sample_data" / "thermostat.csv")]
    for res in results:
        d = res.to_dict()
        assert isinstance(d, dict) and d
        frame = res.to_frame()
        assert isinstance(frame, pd.DataFrame) and len(frame) > 0
        html = res._repr_html_()
        assert "<table" in html and type(res).__name__ in repr(res)
        fig = res.plot()
        assert fig.axes
        plt.close(fig)
        fig2, ax = plt.subplots()
        assert res.plot(ax=ax) is ax and ax.has_data()
        plt.close(fig2)


def test_inputs_give_the_same_numbers(sim):
    """A simulation, its DataFrame and its numpy array are the same log."""
    frame = sim.to_frame()
    a = gyrotest.allan(sim, terms="N", diagnose=False).to_frame()
    b = gyrotest.allan(frame, profile=sim.profile, terms="N", diagnose=False).to_frame()
    c = gyrotest.allan(frame["omega_dph"].to_numpy(), sample_interval="100ms", unit="deg/h",
                       terms="N", diagnose=False).to_frame()
    for other in (b, c):
        np.testing.assert_allclose(other["sigma_dph"], a["sigma_dph"], rtol=1e-12)


def test_api_errors_are_gyrotest_errors(tmp_path):
    x = np.zeros(100)
    with pytest.raises(gyrotest.OptionError) as e:
        gyrotest.allan(x, unit="deg/s")
    assert e.value.fix and "sample_interval" in e.value.fix and e.value.exit_code == 2
    with pytest.raises(gyrotest.OptionError):
        gyrotest.allan(x, sample_interval=0.1, unit="deg/s", dev="nodev")
    with pytest.raises(gyrotest.OptionError, match="rate_cols"):
        gyrotest.read(x, sample_interval=0.1, unit="deg/s", rate_cols="x")
    with pytest.raises(gyrotest.InputError) as e:
        gyrotest.read(tmp_path / "missing.csv")
    assert "missing.csv" in str(e.value)
    with pytest.raises(gyrotest.GyrotestError):
        gyrotest.bias(x[:3], sample_interval=1, unit="deg/h")


def test_readme_python_block_runs(monkeypatch):
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    block = readme.split("## In Python", 1)[1].split("```python\n", 1)[1].split("```", 1)[0]
    monkeypatch.chdir(ROOT)
    ns: dict = {}
    exec(compile(block, "README.md (In Python)", "exec"), ns)
    assert ns["res"].term("N").status == "identified" and len(ns["bias"].to_frame()) == 2
    import matplotlib.pyplot as plt

    plt.close("all")


#: the analysis entry points behind the API: the commands reach them only through it
ENGINE = ("analyse_allan", "analyse_bias_axes", "reduce_logs", "reduce_table",
          "analyse_thermal", "analyse_mag", "fit_log", "diagnose_log", "make_report",
          "envmodel.compensation import", "simulation import simulate", "ingest import read_log")


def test_commands_call_the_api_not_the_engine():
    for f in sorted((ROOT / "gyrotest" / "cli").glob("*.py")):
        code = "\n".join(ln for ln in f.read_text(encoding="utf-8").splitlines()
                         if not ln.lstrip().startswith("#"))
        code = re.sub(r'"""(.*?)"""', "", code, flags=re.S)
        used = [e for e in ENGINE if re.search(rf"\b{re.escape(e)}\b", code)]
        assert not used, f"{f.name} calls {used} directly; call the gyrotest function"


if __name__ == "__main__":
    if sys.argv[1:] == ["--update"]:
        SURFACE.write_text(surface(), encoding="utf-8")
        print(f"wrote {SURFACE}")
