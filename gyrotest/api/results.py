"""The result objects of the Python API.

Each result holds the analysis object its command renders (``.core``: an
:class:`~gyrotest.noise.allanresult.AllanAnalysis`, a :class:`~gyrotest.staticbias.multiaxis.BiasAxes`,
an :class:`~gyrotest.envmodel.modelfit.FitResult` ...) and reads through to its attributes
(``res.axes``, ``res.coefficients``), and adds the same four things to every kind:

* ``to_dict()`` -- the command's ``--json`` document, built by the same function;
* ``to_frame()`` -- a tidy :class:`pandas.DataFrame`, units in the column names;
* ``plot(ax=None)`` -- without ``ax`` the figure the command's ``--plot`` writes (a
  :class:`matplotlib.figure.Figure`); with ``ax`` the main panel drawn on that Axes (returned);
* ``_repr_html_()`` -- a summary and the frame, for notebooks.

The results of the drift-model functions are in :mod:`.modelresults`.

The engine behind a result can change (the workbench's verdict engine is being rebuilt):
scripts that use these four methods and the documented attributes keep working.
"""

from __future__ import annotations

import html
import math
from typing import Any


class Result:
    """Base class of the API's results (module docstring).

    Attributes
    ----------
    core : object
        The analysis object the command line renders; attributes not found on the result are
        read from it.
    """

    __slots__ = ("core", "_meta")

    #: a few words for the HTML summary and ``repr``
    title = "gyrotest result"

    def __init__(self, core: Any, **meta: Any) -> None:
        self.core = core
        self._meta = meta

    def __getattr__(self, name: str) -> Any:
        if name.startswith("__") or name in ("core", "_meta"):
            raise AttributeError(name)
        return getattr(self.core, name)

    def __dir__(self) -> list[str]:
        return sorted(set(super().__dir__()) | set(dir(self.core)))

    # ------------------------------------------------------------------ the four methods
    def to_dict(self) -> dict[str, Any]:
        """The command's ``--json`` document (JSON-ready: units in the key names)."""
        raise NotImplementedError

    def to_json(self, indent: int | None = 2) -> str:
        """:meth:`to_dict` as JSON text, exactly as the command's ``--json`` prints it."""
        from ..core.output import dumps

        return dumps(self.to_dict(), indent=indent)

    def to_frame(self):
        """A tidy :class:`pandas.DataFrame` of the result, units in the column names."""
        raise NotImplementedError

    def plot(self, ax=None):
        """Plot the result.

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Draw the main panel on these axes. Without it, the figure the command's ``--plot``
            writes is made.

        Returns
        -------
        matplotlib.figure.Figure or matplotlib.axes.Axes
            The new figure (``ax`` None) or ``ax``.
        """
        if ax is None:
            return self._figure()
        self._draw(ax)
        return ax

    def _figure(self):
        from ..core.plotting import new_figure

        fig, ax = new_figure()
        self._draw(ax)
        return fig

    def _draw(self, ax) -> None:  # pragma: no cover - every kind has its own
        raise NotImplementedError

    def summary(self) -> list[str]:
        """The headline lines (for ``repr`` and notebooks)."""
        return []

    def __repr__(self) -> str:
        lines = self.summary()
        return f"<{type(self).__name__}: " + ("; ".join(lines) if lines else self.title) + ">"

    def _repr_html_(self) -> str:
        head = f"<strong>{html.escape(self.title)}</strong>"
        items = "".join(f"<li>{html.escape(s)}</li>" for s in self.summary())
        try:
            table = self.to_frame().to_html(max_rows=20, float_format=lambda v: f"{v:.6g}",
                                            index=False, border=0)
        except Exception as e:  # a summary without the table is better than no repr
            table = f"<p>(no table: {html.escape(str(e))})</p>"
        return f"<div>{head}<ul>{items}</ul>{table}</div>"


def _num(x) -> float:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return math.nan
    return v


def _frame(rows: list[dict], columns: list[str] | None = None):
    import pandas as pd

    return pd.DataFrame(rows, columns=columns)


# ============================================================================== allan
class AllanResult(Result):
    """The Allan analysis of one or more logs (:func:`gyrotest.allan`).

    ``res.logs`` holds one :class:`~gyrotest.noise.allanresult.AllanAnalysis` per log; the
    attributes of the first (``axes``, ``tau0``, ``source`` ...) are read through. Noise
    terms: :meth:`term`; the deviation table: :meth:`to_frame`; every fitted term:
    :meth:`terms`.
    """

    __slots__ = ()
    title = "Allan analysis"

    @property
    def logs(self) -> list:
        """One :class:`~gyrotest.noise.allanresult.AllanAnalysis` per log, in the order given."""
        return self.core

    def __getattr__(self, name: str) -> Any:
        if name.startswith("__") or name in ("core", "_meta"):
            raise AttributeError(name)
        return getattr(self.core[0], name)

    @classmethod
    def concat(cls, results) -> AllanResult:
        """One result of several.

        Parameters
        ----------
        results : sequence of AllanResult
            Results to join, the logs of each in order.

        Returns
        -------
        AllanResult
        """
        return cls([a for r in results for a in (r.logs if isinstance(r, AllanResult) else [r])])

    def to_dict(self, *, csv: str | None = None, plot: str | None = None,
                psd: str | None = None) -> dict[str, Any]:
        """The ``gyrotest allan --json`` document.

        Parameters
        ----------
        csv, plot, psd : str, optional
            Files written (the command's ``--csv``, ``--plot``, ``--psd``), listed under
            ``files``.

        Returns
        -------
        dict
            ``{"analysis": "allan", "logs": [...], "files": {...}}``.
        """
        from ..noise.allanresult import allan_document

        return allan_document(self.core, csv=csv, plot=plot, psd=psd)

    def term(self, key: str, axis: str | None = None, log: int = 0):
        """A fitted noise term of the requested model.

        Parameters
        ----------
        key : str
            ``"N"``, ``"B"``, ``"K"``, ``"Q"``, ``"R"``, ``"markov"`` ...
        axis : str, optional
            Rate axis (default the first).
        log : int, default 0
            Index of the log (several logs: ``res.logs``).

        Returns
        -------
        FitTerm or None
            ``value``, ``sigma`` (1σ by parameter), ``upper`` (95 % bound), ``status``
            (identified / upper bound), ``units``, ``text()``; None when not fitted.
        """
        a = self.core[log].axis(axis)
        return None if a.fit is None else a.fit.term(key)

    def to_frame(self):
        """The deviation table: one row per log, axis and τ.

        Columns: ``source``, ``axis``, ``deviation``, ``tau_s``, ``m``, ``n``, ``alpha``,
        ``edf``, ``sigma_lo_dph``, ``sigma_dph``, ``sigma_hi_dph`` (the Stable32 interval at
        the stated confidence) and, where the noise model was fitted, ``model_dph``,
        ``residual_ci`` (residual in CI units) and ``fitted``.
        """
        rows = []
        for r in self.core:
            for a in r.axes:
                tab = a.table()
                for i in range(len(tab["tau"])):
                    row = {"source": r.source, "axis": a.axis, "deviation": a.dev.kind,
                           "tau_s": float(tab["tau"][i]), "m": int(tab["m"][i]),
                           "n": int(tab["n"][i]), "alpha": int(tab["alpha"][i]),
                           "edf": float(tab["edf"][i]),
                           "sigma_lo_dph": float(tab["sigma_lo"][i]),
                           "sigma_dph": float(tab["sigma"][i]),
                           "sigma_hi_dph": float(tab["sigma_hi"][i])}
                    if "model" in tab:
                        row.update(model_dph=float(tab["model"][i]),
                                   residual_ci=float(tab["residual_ci"][i]),
                                   fitted=bool(tab["fitted"][i]))
                    rows.append(row)
        return _frame(rows)

    def terms(self):
        """Every fitted noise term: one row per log, axis, term and parameter.

        Columns: ``source``, ``axis``, ``term``, ``parameter``, ``value``, ``sigma``
        (1σ), ``upper_95`` (the bound of a term that is not identified), ``unit``,
        ``status``.
        """
        rows = []
        for r in self.core:
            for a in r.axes:
                if a.fit is None:
                    continue
                for t in a.fit.terms:
                    for p, v in t.params.items():
                        rows.append({"source": r.source, "axis": a.axis, "term": t.label,
                                     "parameter": p, "value": _num(v),
                                     "sigma": _num(t.sigma.get(p)),
                                     "upper_95": _num(t.upper) if p == t.main else math.nan,
                                     "unit": t.units.get(p, ""), "status": t.status})
        return _frame(rows, ["source", "axis", "term", "parameter", "value", "sigma",
                             "upper_95", "unit", "status"])

    def summary(self) -> list[str]:
        out = []
        for r in self.core:
            for a in r.axes:
                head = f"{r.source} [{a.axis}]"
                fit = a.fit
                if fit is None:
                    out.append(f"{head}: {len(a.dev.tau)} τ, no noise model")
                    continue
                out.append(f"{head}: " + "; ".join(t.text() for t in fit.terms)
                           + f" (χ²/dof = {fit.chi2_dof:.2f}, p = {fit.p_value:.2g})")
        return out

    def _items(self):
        return [(r.source, a) for r in self.core for a in r.axes]

    def _figure(self):
        from ..noise.plots import figure_allan

        return figure_allan(self._items())

    def _draw(self, ax) -> None:
        import numpy as np

        for src, a in self._items():
            tab = a.table()
            tau, s = np.asarray(tab["tau"]), np.asarray(tab["sigma"])
            err = [s - np.asarray(tab["sigma_lo"]), np.asarray(tab["sigma_hi"]) - s]
            line = ax.errorbar(tau, s, yerr=err, fmt="o", ms=3, capsize=2,
                               label=f"{src} [{a.axis}] {a.dev.kind.upper()}")
            if "model" in tab:
                ax.plot(tau, tab["model"], "-", color=line[0].get_color(), lw=1,
                        label="noise model")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("averaging time τ, s")
        ax.set_ylabel("deviation σ(τ), deg/h")
        ax.legend(fontsize=8)


# ============================================================================== bias
class BiasResult(Result):
    """Bias D_F of one or more static runs (:func:`gyrotest.bias`); ``core`` is a
    :class:`~gyrotest.staticbias.multiaxis.BiasAxes` (``per_axis``: one
    :class:`~gyrotest.staticbias.analysis.BiasAnalysis` per axis with ``runs``, ``repeatability`` and
    ``multi``)."""

    __slots__ = ()
    title = "Bias D_F (IEEE 952 §12.11.4.1.1)"

    def to_dict(self) -> dict[str, Any]:
        """The ``gyrotest bias --json`` document."""
        return self.core.to_dict()

    @property
    def bias_dph(self) -> float:
        """D_F of the first axis, deg/h: the multi-position fit's, else the first run's."""
        ba = next(iter(self.core.per_axis.values()))
        return ba.multi.bias_dph if ba.multi else ba.runs[0].bias_dph

    def to_frame(self):
        """One row per axis and run: ``axis``, ``run``, ``duration_s``,
        ``mean_output_dph``, ``earth_rate_ia_dph``, ``bias_dph`` (D_F), ``sigma_dph`` (1σ:
        the Allan deviation at the record length from the fitted noise model) and
        ``naive_sigma_dph`` (σ/√n, for comparison)."""
        rows = []
        for name, ba in self.core.per_axis.items():
            for r in ba.runs:
                rows.append({"axis": name, "run": r.label, "duration_s": r.duration_s,
                             "mean_output_dph": r.mean_output_dph,
                             "earth_rate_ia_dph": _num(r.earth_rate_ia_dph),
                             "bias_dph": _num(r.bias_dph) if not ba.multi else math.nan,
                             "sigma_dph": r.sigma_dph,
                             "naive_sigma_dph": r.uncertainty.naive_sigma_dph})
        return _frame(rows)

    def summary(self) -> list[str]:
        out = []
        for name, ba in self.core.per_axis.items():
            if ba.multi:
                m = ba.multi
                out.append(f"axis {name}: multi-position D_F = {m.bias_dph:.6g} ± "
                           f"{m.bias_sigma_dph:.3g} deg/h")
                continue
            for r in ba.runs:
                out.append(f"axis {name}, {r.label}: D_F = {r.bias_dph:.6g} ± "
                           f"{r.sigma_dph:.3g} deg/h")
            if ba.repeatability:
                rep = ba.repeatability
                out.append(f"axis {name}: repeatability over {len(rep.runs)} runs: mean "
                           f"{rep.mean_dph:.6g} deg/h, 1σ {rep.sigma_1_dph:.3g} deg/h")
        return out

    def _figure(self):
        from ..staticbias.plots import figure_bias

        return figure_bias(next(iter(self.core.per_axis.values())))

    def _draw(self, ax) -> None:
        df = self.to_frame()
        y = df["bias_dph"].where(df["bias_dph"].notna(), df["mean_output_dph"])
        ax.errorbar(range(len(df)), y, yerr=df["sigma_dph"], fmt="o", capsize=3)
        ax.set_xticks(range(len(df)))
        ax.set_xticklabels([f"{a}: {r.split('/')[-1]}" for a, r in zip(df["axis"], df["run"])],
                           rotation=30, ha="right", fontsize=8)
        ax.set_ylabel("bias D_F ± 1σ, deg/h")


# ============================================================================== scale factor
class ScaleFactorResult(Result):
    """Scale factor, linearity, asymmetry and nonlinearity from rate-table runs
    (:func:`gyrotest.scale_factor`); ``core`` is a
    :class:`~gyrotest.scalefactor.analysis.ScaleFactorResult`."""

    __slots__ = ()
    title = "Scale factor (IEEE 952 §12.9.4)"

    def to_dict(self, *, plot: str | None = None, points_file: str | None = None
                ) -> dict[str, Any]:
        """The ``gyrotest scale-factor --json`` document.

        Parameters
        ----------
        plot, points_file : str, optional
            Files written (``--plot``, ``--points``), named in the document.

        Returns
        -------
        dict
        """
        from ..scalefactor import scale_factor_document

        return scale_factor_document(self.core, plot=plot, points_file=points_file)

    def to_frame(self):
        """The plateau table (one row per plateau and run), as ``--points`` writes it."""
        return _frame(self.core.to_dict()["points"])

    def summary(self) -> list[str]:
        d = self.to_dict()
        u = d.get("scale_factor_unit") or ""
        key = next((k for k in d if k.startswith("scale_factor_") and isinstance(d[k], float)
                    and not any(w in k for w in ("sigma", "model", "error", "nominal"))), None)
        out = [f"{len(d.get('points', []))} plateaus"]
        if key:
            sig = d.get(key.replace("scale_factor_", "scale_factor_sigma_"))
            out.append(f"scale factor {d[key]:.9g}" + (f" ± {sig:.2g}" if sig else "")
                       + f" {u}".rstrip())
        if isinstance(d.get("scale_factor_error_ppm"), float):
            out.append(f"scale-factor error {d['scale_factor_error_ppm']:.4g} ppm")
        return out

    def _figure(self):
        from ..scalefactor.plots import figure_scale_factor

        return figure_scale_factor(self.core, logs=self._meta.get("logs"))

    def _draw(self, ax) -> None:
        df = self.to_frame()
        y = "model_residual_ppm_fs" if "model_residual_ppm_fs" in df else "linearity_ppm_fs"
        ax.errorbar(df["input_rate_dph"] / 3600.0, df[y], yerr=df["stderr_ppm_fs"], fmt="o",
                    ms=4, capsize=2)
        ax.axhline(0, color="0.6", lw=0.8)
        ax.set_xlabel("input rate, deg/s")
        ax.set_ylabel(y.replace("_ppm_fs", ", ppm of full scale").replace("_", " "))


# ============================================================================== campaign
class Report(Result):
    """The spec sheet of a campaign (:func:`gyrotest.report`); ``core`` is the
    :class:`~gyrotest.specsheet.sheet.Sheet` (``checks``, ``sections``, ``overall()``)."""

    __slots__ = ()
    title = "Specification sheet"

    def to_dict(self) -> dict[str, Any]:
        """The ``gyrotest report --json`` document."""
        return self.core.to_dict()

    def to_frame(self):
        """The compliance checks: ``item``, ``ieee``, ``value``, ``sigma``, ``unit``,
        ``limit``, ``expanded_uncertainty`` and ``verdict`` under the stated decision
        rule."""
        rows = []
        for c in self.core.checks:
            m = c.measured
            rows.append({"item": c.label, "ieee": c.ieee,
                         "value": _num(m.value) if m else math.nan,
                         "sigma": _num(m.sigma) if m else math.nan, "unit": c.unit,
                         "limit": _num(c.limit), "expanded_uncertainty": c.expanded_uncertainty,
                         "verdict": c.verdict})
        return _frame(rows, ["item", "ieee", "value", "sigma", "unit", "limit",
                             "expanded_uncertainty", "verdict"])

    def to_markdown(self) -> str:
        """The sheet as Markdown (as ``gyrotest report`` prints it)."""
        from ..specsheet.markdown import render_markdown

        return render_markdown(self.core, None)

    def to_html(self) -> str:
        """The sheet as one self-contained HTML document."""
        from ..specsheet.html import render_html

        return render_html(self.core)

    def to_pdf(self, path) -> int:
        """Write the sheet as PDF.

        Parameters
        ----------
        path : str or os.PathLike
            The PDF file (written atomically).

        Returns
        -------
        int
            The number of pages.
        """
        from ..core.output import write_rendered
        from ..specsheet.pdf import render_pdf

        data, pages = render_pdf(self.core)
        write_rendered(pdf=path, pdf_bytes=data)
        return pages

    def summary(self) -> list[str]:
        return [f"{self.core.title}: {self.core.overall()}"]

    def _draw(self, ax) -> None:
        df = self.to_frame().dropna(subset=["value", "limit"])
        df = df[df["limit"] > 0]
        ratio = df["value"].abs() / df["limit"]
        ax.barh(range(len(df)), ratio, xerr=df["expanded_uncertainty"] / df["limit"],
                color=["#009E73" if v == "PASS" else "#D55E00" for v in df["verdict"]])
        ax.axvline(1.0, color="k", lw=1)
        ax.set_yticks(range(len(df)))
        ax.set_yticklabels(df["item"], fontsize=8)
        ax.invert_yaxis()
        ax.set_xlabel("|measured| / limit (bar: expanded uncertainty U, k = 2)")


class Simulation(Result):
    """A simulated bench log with known truth (:func:`gyrotest.simulate`); ``core`` is a
    :class:`~gyrotest.simulation.simrun.SimResult` (``runs``, ``truth``, ``columns``)."""

    __slots__ = ()
    title = "Simulated bench log"

    def write(self, path, format: str | None = None):
        """Write the log(s) with the ``.truth.json`` and ``.profile.toml`` beside each.

        Parameters
        ----------
        path : str or os.PathLike
            The log file (several runs: ``<stem>_run1<ext>`` ...).
        format : {"csv", "parquet", "feather"}, optional
            Default from the suffix.

        Returns
        -------
        WriteResult
            The paths written (``.to_dict()`` for JSON).
        """
        from ..core.errors import InputError
        from ..simulation import write_log

        try:
            return write_log(self.core, path, fmt=format)
        except OSError as e:
            raise InputError(f"cannot write {path}: {e.strerror or e}") from None

    def to_dict(self, *, written=None) -> dict[str, Any]:
        """The ``gyrotest simulate --json`` document (without its timings).

        Parameters
        ----------
        written : WriteResult, optional
            What :meth:`write` returned; without it ``files`` is None.

        Returns
        -------
        dict
        """
        res = self.core
        r0 = res.runs[0]
        return {"scenario": res.name, "seed": res.seed, "runs": len(res.runs),
                "samples": [r.n for r in res.runs], "sample_rate_hz": 1.0 / r0.tau0,
                "duration_s": r0.n * r0.tau0,
                "files": written.to_dict() if written is not None else None,
                "truth": res.truth}

    def to_frame(self, run: int = 0):
        """The samples of a run as the log file holds them.

        Parameters
        ----------
        run : int, default 0
            Index of the run.

        Returns
        -------
        pandas.DataFrame
            Column names carry the units: ``t_s``, ``omega_dph``, ``T_case_C`` ...
        """
        import pandas as pd

        return pd.DataFrame(dict(self.core.runs[run].columns))

    def summary(self) -> list[str]:
        r0 = self.core.runs[0]
        return [f"{self.core.name}: {len(self.core.runs)} run(s) of {r0.n} samples at "
                f"{1.0 / r0.tau0:g} Hz (seed {self.core.seed})"]

    def _draw(self, ax) -> None:
        import numpy as np

        r0 = self.core.runs[0]
        n = max(1, r0.n // 2000)
        m = r0.n // n * n
        t = np.asarray(r0.t[:m]).reshape(-1, n).mean(axis=1)
        y = np.asarray(r0.rate_dph[:m]).reshape(-1, n).mean(axis=1)
        ax.plot(t, y, lw=0.8)
        ax.set_xlabel("time, s")
        ax.set_ylabel(f"rate ({n}-sample means), deg/h")
