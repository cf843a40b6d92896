"""``gyrotest compensate``: apply a fitted model to another run (the transfer test)."""

from __future__ import annotations

import click
from rich.markup import escape

from ..core.output import LOG_SUFFIXES
from .cmd_model import check_output, write_plot
from .common import (
    console,
    emit_json,
    fmt_num,
    ingest_options,
    json_option,
    load_for_terms,
    note,
    plot_option,
    warn,
    with_ingest,
)


@click.command("compensate")
@click.argument("log", type=str)
@click.option("--model", "model_path", required=True, type=click.Path(dir_okay=False),
              help="Model file from 'gyrotest model fit -o', thermal-fit or mag-fit.")
@click.option("-o", "--output", default=None,
              help="Write the compensated log (.parquet or .feather, with metadata and the "
                   "model drift as column model_drift_dph).")
@click.option("--keep-bias", is_flag=True, help="Do not subtract the model's constant bias.")
@click.option("--force", is_flag=True,
              help="Allow -o to replace LOG itself with the compensated log; without it an "
                   "output that is one of the inputs is refused.")
@plot_option("Drift and Allan deviation before/after (.png/.svg/.pdf).")
@ingest_options
@json_option
@with_ingest
def command(log, model_path, output, keep_bias, force, plot_path, as_json, ingest_opts):
    """Subtract a model's drift from LOG and report the drift before and after.

    The transfer test a lab does before trusting a compensation: fit on one run, apply to
    another with the same physics. Drift RMS and peak-to-peak are compared at the model's
    working resolution, with the reduction the model predicts (its held-out RMS on the
    fitting run); the Allan deviation before and after shows what changed at every τ.

    \b
    Example:
      gyrotest model fit sample_data/static.parquet --profile sample_data/static.profile.toml \\
          --terms "T(T_case_C)" -o model.json
      gyrotest compensate sample_data/bias_run2.parquet \\
          --profile sample_data/bias_run2.profile.toml --model model.json -o run2_comp.parquet
    """
    from ..api.models import compensate
    from ..envmodel.model import EnvModel

    out_path = check_output(output, LOG_SUFFIXES, "output file")
    if plot_path:
        from ..core.plotting import check_plot_path

        check_plot_path(plot_path)
    model = EnvModel.load(model_path)
    g = load_for_terms(log, ingest_opts, model.specs, announce=not as_json)
    cp = compensate(g, model, keep_bias=keep_bias)  # gyrotest.compensate
    if out_path:
        from ..io.ingest import write_log

        write_log(cp.log, out_path)
    if plot_path:
        from ..envmodel.plots import compensation_figures

        write_plot(compensation_figures(cp), plot_path)
    for w in cp.warnings:
        warn(w)
    if as_json:
        d = cp.to_dict(output=str(out_path) if out_path else None)
        d["model_file"] = str(model_path)
        emit_json(d)
        return
    c = console()
    c.print(f"[bold]compensate[/bold]: {escape(g.source)} with {escape(str(model_path))} "
            f"({' + '.join(cp.model_terms)})")
    c.print(f"  drift RMS at {cp.resolution_s:g} s: before {fmt_num(cp.rms_before_dph)} deg/h, "
            f"after [bold]{fmt_num(cp.rms_after_dph)}[/bold] deg/h → ×{fmt_num(cp.factor, 3)} "
            f"(model predicts ×{fmt_num(cp.predicted_factor, 3)}: held-out RMS "
            f"{fmt_num(cp.predicted_rms_after_dph)} deg/h)")
    c.print(f"  drift peak-to-peak: before {fmt_num(cp.p2p_before_dph)}, after "
            f"{fmt_num(cp.p2p_after_dph)} deg/h")
    import numpy as np

    picks = [i for i, t in enumerate(cp.adev_tau) if any(abs(np.log(t / x)) < 0.35
                                                          for x in (1, 10, 100, 1000, 10000))]
    if picks:
        c.print("  Allan deviation before → after: " + ", ".join(
            f"σ({cp.adev_tau[i]:.3g} s) {fmt_num(cp.adev_before[i], 3)} → "
            f"{fmt_num(cp.adev_after[i], 3)}" for i in picks) + " deg/h")
    ratio = cp.factor / cp.predicted_factor if cp.predicted_factor else float("nan")
    if ratio < 0.8:
        warn(f"the compensation achieves only {ratio:.0%} of the predicted reduction: the model "
             "does not transfer to this run (different physics, range or setup)")
    if out_path:
        c.print(f"  compensated log written to {escape(str(out_path))}")
    elif not as_json:
        note("add -o out.parquet to keep the compensated log")

