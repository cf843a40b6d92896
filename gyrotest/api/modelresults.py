"""The result objects of the drift-model functions (:func:`gyrotest.thermal_fit`,
:func:`gyrotest.mag_fit`, :class:`gyrotest.Model`, :func:`gyrotest.compensate`): the same
to_dict() / to_frame() / plot() / HTML interface as the other results
(:class:`~gyrotest.api.results.Result`)."""

from __future__ import annotations

from typing import Any

from .results import Result, _frame, _num


# ============================================================================== workbench
def _coef_rows(coefs, group: str) -> list[dict]:
    return [{"group": group, "name": c.name, "value": c.value, "sigma": c.stderr,
             "unit": c.unit} for c in coefs]


class ThermalResult(Result):
    """The thermal drift model of a chamber run and/or a set-point table
    (:func:`gyrotest.thermal_fit`); ``core`` is a
    :class:`~gyrotest.envmodel.domain.ThermalAnalysis` (``chamber``, ``setpoints``)."""

    __slots__ = ()
    title = "Thermal drift model (Antonova–Matveev; IEEE 952 D_T, D_Ṫ, D_∇Ṫ)"

    def to_dict(self, *, model_file: str | None = None) -> dict[str, Any]:
        """The ``gyrotest thermal-fit --json`` document.

        Parameters
        ----------
        model_file : str, optional
            The model file written (``-o``), named in the document.

        Returns
        -------
        dict
        """
        return self.core.to_dict(model_file=model_file)

    def coef(self, name: str):
        """A coefficient by name.

        Parameters
        ----------
        name : str
            ``"w0"``, ``"w1"``, ``"w2"``, ``"w_dV"``, ``"D_T"``, ``"D_Tdot"``,
            ``"D_gradTdot"`` ...

        Returns
        -------
        Coef
            ``value``, ``stderr`` (1σ) and ``unit``.
        """
        for part in (self.core.chamber, self.core.setpoints):
            if part is not None:
                try:
                    return part.coef(name)
                except KeyError:
                    pass
        raise KeyError(name)

    @property
    def model(self):
        """The fitted chamber-run model (an :class:`~gyrotest.envmodel.model.EnvModel` for
        :func:`gyrotest.compensate`; ``.save(path)``), or None from set-points alone."""
        return self.core.chamber.am.model if self.core.chamber else None

    def to_frame(self):
        """Every coefficient: ``group`` (Antonova–Matveev, IEEE E terms, set-points),
        ``name``, ``value``, ``sigma`` (1σ, GLS under the noise model for a chamber run), ``unit``."""
        rows = []
        th, sp = self.core.chamber, self.core.setpoints
        if th:
            rows += _coef_rows(th.coefficients, "Antonova-Matveev")
            rows += _coef_rows(th.ieee_coefficients, "IEEE E terms")
        if sp:
            rows += _coef_rows(sp.coefficients, "set-points")
        return _frame(rows, ["group", "name", "value", "sigma", "unit"])

    def summary(self) -> list[str]:
        return [f"{r.group} {r.name} = {r.value:.4g} ± {r.sigma:.2g} {r.unit}"
                for r in self.to_frame().itertuples()]

    def _figure(self):
        from ..envmodel.plots import setpoint_figures, thermal_figures

        th, sp = self.core.chamber, self.core.setpoints
        return _first_figure((thermal_figures(th) if th else [])
                             + (setpoint_figures(sp) if sp else []))

    def _draw(self, ax) -> None:
        _coef_bars(ax, self.to_frame())


def _first_figure(figs):
    """The first of a command's ``(name, figure)`` list; the others are closed."""
    import matplotlib.pyplot as plt

    for _, f in figs[1:]:
        plt.close(f)
    return figs[0][1]


def _coef_bars(ax, df) -> None:
    ax.errorbar(df["value"], range(len(df)), xerr=df["sigma"], fmt="o", capsize=3)
    ax.set_yticks(range(len(df)))
    ax.set_yticklabels([f"{n} [{u}]" for n, u in zip(df["name"], df["unit"])], fontsize=8)
    ax.axvline(0, color="0.6", lw=0.8)
    ax.set_xlabel("coefficient ± 1σ (unit per row)")


class MagResult(Result):
    """Magnetic sensitivities from a Helmholtz-coil run (:func:`gyrotest.mag_fit`);
    ``core`` is a :class:`~gyrotest.envmodel.domain.MagResult`."""

    __slots__ = ()
    title = "Magnetic sensitivity (IEEE 952 §5.3.3.2), deg/h per 100 µT"

    def to_dict(self, *, model_file: str | None = None) -> dict[str, Any]:
        """The ``gyrotest mag-fit --json`` document.

        Parameters
        ----------
        model_file : str, optional
            The model file written (``-o``), named in the document.

        Returns
        -------
        dict
        """
        from ..envmodel.domain import mag_document

        return mag_document(self.core, model_file=model_file)

    @property
    def model(self):
        """The fitted model (:class:`~gyrotest.envmodel.model.EnvModel`; ``.save(path)``)."""
        return self.core.fit.model

    def to_frame(self):
        """One row per field axis: ``name``, ``value`` and ``sigma`` (1σ) in deg/h per
        100 µT, ``reversal_K_dph_per_100uT`` (signed reversal estimate) and
        ``up_minus_down_dph`` with its ``up_minus_down_sigma_dph`` (sweep hysteresis)."""
        rows = []
        for c in self.core.coefficients:
            a = c.name[-1]
            rv = self.core.reversal.get(a) or {}
            hy = self.core.hysteresis.get(a) or {}
            rows.append({"name": c.name, "value": c.value, "sigma": c.stderr, "unit": c.unit,
                         "reversal_K_dph_per_100uT": _num(rv.get("signed_dph_per_100uT")),
                         "up_minus_down_dph": _num(hy.get("up_minus_down_dph")),
                         "up_minus_down_sigma_dph": _num(hy.get("stderr_dph"))})
        return _frame(rows)

    def summary(self) -> list[str]:
        return [f"{c.name} = {c.value:.4g} ± {c.stderr:.2g} {c.unit}"
                for c in self.core.coefficients]

    def _figure(self):
        from ..envmodel.plots import mag_figures

        return _first_figure(mag_figures(self.core))

    def _draw(self, ax) -> None:
        _coef_bars(ax, self.to_frame())


class ModelFit(Result):
    """A drift model fitted to a log (:meth:`gyrotest.Model.fit`); ``core`` is the
    workbench's fit result (``coefficients``, ``rms_fit``, ``rms_holdout``, ``floor``,
    ``excursions``, ``model``)."""

    __slots__ = ()
    title = "Drift model fit"

    def to_dict(self, *, written: dict | None = None) -> dict[str, Any]:
        """The ``gyrotest model fit --json`` document.

        Parameters
        ----------
        written : dict, optional
            The model and history files written (``-o``, ``--session``).

        Returns
        -------
        dict
        """
        from ..envmodel.modelfit import fit_document

        return fit_document(self.core, written=written)

    def save(self, path) -> None:
        """Write the fitted model for :func:`gyrotest.compensate` or ``gyrotest compensate``.

        Parameters
        ----------
        path : str or os.PathLike
            A .json or .toml file (written atomically).
        """
        self.core.model.save(path)

    def to_frame(self):
        """One row per coefficient: ``name``, ``term``, ``value``, ``sigma`` (1σ, GLS under
        the noise model), ``unit``, ``z``, ``significance``."""
        return _frame([{"name": c.name, "term": c.term, "value": c.value, "sigma": c.stderr,
                        "unit": c.unit, "z": c.z, "significance": c.significance}
                       for c in self.core.coefficients])

    def summary(self) -> list[str]:
        r = self.core
        out = [f"terms {' + '.join(r.terms) or '(bias only)'}",
               f"residual RMS: fit {r.rms_fit:.4g} deg/h, held-out {r.rms_holdout:.4g} deg/h"]
        out.append(f"noise model: {r.noise.params.text()}; log-likelihood {r.loglik:.1f}")
        return out

    def _figure(self):
        from ..envmodel.plots import fit_figures

        return _first_figure(fit_figures(self.core))

    def _draw(self, ax) -> None:
        _coef_bars(ax, self.to_frame())


class ModelDiagnosis(Result):
    """Which effect the model lacks (:meth:`gyrotest.Model.diagnose`); ``core`` is the
    workbench's diagnosis (``verdict``, ``candidates`` best first, ``found``, ``path``,
    ``base``)."""

    __slots__ = ()
    title = "Model diagnosis"

    def to_dict(self) -> dict[str, Any]:
        """The ``gyrotest model diagnose --json`` document."""
        return self.core.to_dict()

    @property
    def missing(self) -> str | None:
        """The term text of the missing effect (None when none was found)."""
        return self.core.found[0].term if self.core.found else None

    def to_frame(self):
        """The candidate terms, most significant first: ``term``, ``effect``, ``lr``
        (likelihood ratio), ``df``, ``p``, ``p_family`` (family-wise), ``delta_bic``,
        ``significant``."""
        return _frame([{"term": c.term, "effect": c.effect, "lr": c.lr, "df": c.df, "p": c.p,
                        "p_family": c.p_family, "delta_bic": c.dbic,
                        "significant": c.significant}
                       for c in self.core.candidates],
                      ["term", "effect", "lr", "df", "p", "p_family", "delta_bic",
                       "significant"])

    def summary(self) -> list[str]:
        return [self.core.verdict]

    def _figure(self):
        from ..envmodel.plots import diagnosis_figures

        return _first_figure(diagnosis_figures(self.core))

    def _draw(self, ax) -> None:
        import numpy as np

        df = self.to_frame().head(12)
        ax.barh(range(len(df)), np.maximum(df["lr"].to_numpy(float), 1e-3),
                color=["#009E73" if s else "#999999" for s in df["significant"]])
        ax.set_yticks(range(len(df)))
        ax.set_yticklabels(df["term"], fontsize=8)
        ax.invert_yaxis()
        ax.set_xscale("log")
        ax.set_xlabel("likelihood ratio Λ (log scale)")


class CompensationResult(Result):
    """A drift model applied to another run (:func:`gyrotest.compensate`); ``core`` has
    the drift before and after (``rms_before_dph``, ``rms_after_dph``, ``factor``), the Allan
    deviation before and after, and the compensated ``log``."""

    __slots__ = ()
    title = "Compensation"

    def to_dict(self, *, output: str | None = None) -> dict[str, Any]:
        """The ``gyrotest compensate --json`` document.

        Parameters
        ----------
        output : str, optional
            The compensated log written (``-o``).

        Returns
        -------
        dict
        """
        d = self.core.to_dict()
        d["output"] = output
        d["model_file"] = self._meta.get("model_file")
        return d

    def to_frame(self):
        """The Allan deviation before and after: ``tau_s``, ``sigma_before_dph``,
        ``sigma_after_dph``."""
        c = self.core
        return _frame({"tau_s": list(map(float, c.adev_tau)),
                       "sigma_before_dph": list(map(float, c.adev_before)),
                       "sigma_after_dph": list(map(float, c.adev_after))})

    def summary(self) -> list[str]:
        c = self.core
        return [f"drift RMS {c.rms_before_dph:.4g} → {c.rms_after_dph:.4g} deg/h "
                f"(×{c.factor:.3g}; the model predicts ×{c.predicted_factor:.3g})"]

    def _figure(self):
        from ..envmodel.plots import compensation_figures

        return _first_figure(compensation_figures(self.core))

    def _draw(self, ax) -> None:
        df = self.to_frame()
        ax.loglog(df["tau_s"], df["sigma_before_dph"], "o-", ms=3, label="before")
        ax.loglog(df["tau_s"], df["sigma_after_dph"], "o-", ms=3, label="after")
        ax.set_xlabel("averaging time τ, s")
        ax.set_ylabel("Allan deviation, deg/h")
        ax.legend()
