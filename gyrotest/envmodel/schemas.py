"""Schemas of the JSON/TOML result files gyrotest reads back: a drift model
(``model fit -o``, ``thermal-fit -o``, ``mag-fit -o``; read by ``compensate --model``, ``allan
--model``, ``export env-model``) and a model history (``model history``).

Each ``*_problems`` function returns every problem, one line each naming its key path
(``terms[3].coefficients[0].value: must be a number, got None``); the loaders raise them as
one :class:`gyrotest.core.documents.DocumentError`. The schema language is
:func:`gyrotest.core.documents.check_schema`'s. Tables are open where the writer may add keys in a
later version (``fit``, ``data``) and closed where a misspelt key would be silently ignored.
"""

from __future__ import annotations

from typing import Any

from ..core.documents import check_schema, jsonpath

#: the ``format`` of a drift-model file and of a model history (written by
#: :mod:`.model` and :mod:`.history`, checked here)
FORMAT = "gyrotest-envmodel"
HISTORY_FORMAT = "gyrotest-model-history"

_COEF = {"name": "str", "symbol": "str?", "value!": "num", "stderr": "real?", "unit": "str"}
_NONLINEAR = {"name!": "str", "value!": "num", "stderr": "real?", "unit": "str"}
_TERM = {"key!": "str", "label": "str", "channels": "strs", "name": "str?", "expr": "str?",
         "effect": "str", "formula": "str", "source": "str", "coefficients!": [_COEF],
         "nonlinear": [_NONLINEAR]}
_REFS = {"T_ref_degC": {"*": "num"}, "V_ref_V": "num?", "H0_uT": "pos",
         "t_power_on_s": "num", "smoothing_window_s": "pos",
         "hysteresis_threshold_degC_per_h": {"*": "num"},
         "hysteresis_min_width_degC": {"*": "num"}}
MODEL_SCHEMA = {"format!": "str", "format_version": "int", "gyrotest_version": "str",
                "created": "str", "equation": "str", "axis": "str", "resolution_s!": "pos",
                "fine_dt_s": "pos", "references": _REFS, "terms!": [_TERM],
                "fit": {"*": "any"}, "data": {"*": "any"}}


def model_problems(d: Any) -> list[str]:
    """Every problem of a parsed model file: types and required keys, unknown term keys, a
    custom term without a string expression or one that does not parse, a coefficient count
    that does not match the term."""
    if not isinstance(d, dict) or d.get("format") != FORMAT:
        got = d.get("format") if isinstance(d, dict) else type(d).__name__
        return [f"not a gyrotest model file (format {got!r}, expected {FORMAT!r}); give a "
                "file written by 'gyrotest model fit -o', thermal-fit -o or mag-fit -o"]
    problems = check_schema(d, MODEL_SCHEMA)
    if problems:
        return problems
    from ..core.errors import InputError
    from .expr import parse_expression
    from .terms import EFFECTS, TermSpec

    for i, t in enumerate(d["terms"]):
        where = ("terms", i)
        if t["key"] not in EFFECTS:
            problems.append(f"{jsonpath((*where, 'key'))}: unknown term {t['key']!r}; known: "
                            + ", ".join(sorted(EFFECTS)))
            continue
        if t["key"] == "custom":
            if not isinstance(t.get("expr"), str) or not isinstance(t.get("name"), str):
                problems.append(f"{jsonpath(where)}: a custom term needs 'name' and 'expr' "
                                "strings")
                continue
            try:
                parse_expression(t["expr"])
            except InputError as e:
                problems.append(f"{jsonpath((*where, 'expr'))}: {e}")
                continue
        try:
            n = TermSpec.from_dict(t).n_coef
        except (InputError, TypeError, ValueError) as e:
            problems.append(f"{jsonpath(where)}: {e}")
            continue
        have = len(t["coefficients"])
        if have != n:
            problems.append(f"{jsonpath((*where, 'coefficients'))}: {have} value(s), the term "
                            f"{t.get('label') or t['key']!r} has {n}")
    if not any(t.get("key") == "bias" for t in d["terms"]):
        problems.append("terms: no 'bias' term; a model always has one")
    return problems


_STEP = {"step!": "int", "time": "str", "log!": "str", "sha256": "str?", "terms!": "strs",
         "added": "strs", "removed": "strs", "n_params": "int", "rms_fit_dph": "real?",
         "rms_holdout_dph": "real?", "aic": "real?", "bic": "real?",
         "noise_floor_dph": "real?", "resolution_s": "real?", "model_file": "str?",
         "extra": {"*": "any"}}
HISTORY_SCHEMA = {"format!": "str", "version": "int", "steps!": [_STEP]}


def history_problems(d: Any) -> list[str]:
    """Every problem of a parsed model history."""
    if not isinstance(d, dict) or d.get("format") != HISTORY_FORMAT:
        return ["not a gyrotest model history (fit with -o MODEL.json or --session DIR first)"]
    return check_schema(d, HISTORY_SCHEMA)
