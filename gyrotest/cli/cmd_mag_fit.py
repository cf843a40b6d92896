"""``gyrotest mag-fit``: magnetic sensitivities w_x, w_y, w_z (deg/h per 100 µT)."""

from __future__ import annotations

import click
from rich.markup import escape

from ..core.units import parse_duration
from .cmd_model import (
    check_output,
    domain_fit_options,
    load_reference,
    render_fit,
    write_plot,
)
from .common import (
    console,
    emit_json,
    fmt_num,
    ingest_options,
    json_option,
    load_for_terms,
    note,
    with_ingest,
)


@click.command("mag-fit")
@click.argument("log", type=str)
@click.option("--with", "with_terms", default=None,
              help="Extra terms for drift between levels, e.g. T or ramp (comma-separated).")
@click.option("--settle", default="10s", show_default=True,
              help="Time dropped after every field step when averaging a plateau.")
@click.option("--min-dwell", default="30s", show_default=True,
              help="Shortest constant-field stretch that counts as a plateau.")
@domain_fit_options(smooth_help="Smoother window W or 'auto'.",
                    plot_help="Plateau means per axis and residual plots (.png/.svg/.pdf).",
                    figures="levels, then the fit's time, channels and allan")
@ingest_options
@json_option
@with_ingest
def command(log, with_terms, settle, min_dwell, axis, skip, resolution, smooth, folds, reference,
            output, plot_path, as_json, ingest_opts):
    """Magnetic model dw = w0 + wx·Hx/H0 + wy·Hy/H0 + wz·Hz/H0 (H0 = 100 µT).

    From a Helmholtz-coil sequence (levels stepped one axis at a time; plateaus and axes are
    detected automatically) or a continuous magnetometer log. Coefficients in deg/h per
    100 µT with 1σ (GLS under the gyro's noise model); cross-checks: the paper's reversal estimate K = |dw(+max) −
    dw(−max)|/(2·max/100 µT) (K = Δω/6 for ±300 µT) and the up/down sweep hysteresis.

    \b
    Examples:
      gyrotest mag-fit sample_data/magnetic.parquet --profile sample_data/magnetic.profile.toml
      gyrotest mag-fit sample_data/magnetic.parquet --profile sample_data/magnetic.profile.toml \\
          --with T -o mag.json
    """
    from ..api.models import mag_fit
    from ..envmodel.domain import mag_terms

    out_path = check_output(output, (".json", ".toml"), "model file")
    if plot_path:
        from ..core.plotting import check_plot_path

        check_plot_path(plot_path)
    _, specs = mag_terms(with_terms)
    settle_s = parse_duration(settle, what="--settle")
    dwell_s = parse_duration(min_dwell, what="--min-dwell")
    g = load_for_terms(log, ingest_opts, specs, announce=not as_json)
    ref = load_reference(reference, ingest_opts, as_json)
    mg = mag_fit(g, with_terms=with_terms, settle=settle_s, min_dwell=dwell_s, axis=axis,
                 skip=skip, resolution=resolution, smooth=smooth, folds=folds, reference=ref)
    if out_path:
        mg.fit.model.save(out_path)
    if plot_path:
        from ..envmodel.plots import mag_figures

        write_plot(mag_figures(mg), plot_path)
    if as_json:
        emit_json(mg.to_dict(model_file=str(out_path) if out_path else None))
        return
    from rich.table import Table

    c = console()
    c.print(f"[bold]mag-fit[/bold]: {escape(g.source)}, {len(mg.plateaus)} plateau(s) detected")
    t = Table(title="magnetic sensitivity, deg/h per 100 µT")
    for col, just in (("axis", "left"), ("w ± 1σ", "right"), ("reversal K (signed)", "right"),
                      ("up − down, deg/h", "right"), ("hysteresis", "left")):
        t.add_column(col, justify=just)
    for co in mg.coefficients:
        a = co.name[-1]
        rv = mg.reversal.get(a)
        hy = mg.hysteresis.get(a)
        t.add_row(a.upper(), f"{fmt_num(co.value)} ± {fmt_num(co.stderr, 2)}",
                  fmt_num(rv["signed_dph_per_100uT"]) if rv else "—",
                  f"{fmt_num(hy['up_minus_down_dph'])} ± {fmt_num(hy['stderr_dph'], 2)}"
                  if hy else "—", hy["verdict"] if hy else "")
    c.print(t)
    for n in mg.notes:
        note(n)
    render_fit(mg.fit, title="fit details")
    if out_path:
        c.print(f"  model written to {escape(str(out_path))}")
