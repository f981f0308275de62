"""Figures: sweeps in the style of the paper's Figures 3 and 4, parameter maps, and the
across-track formation.

Drawn with matplotlib's Agg back end, so it works without a screen (as recorded_plots.py,
the mission report's PNGs; cli/checks.py asks matplotlib only which file types it saves).
"""
from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from uav_insar_planner import model  # noqa: E402
from uav_insar_planner.params import Params  # noqa: E402
from uav_insar_planner.plan import Plan  # noqa: E402
from uav_insar_planner.report.scene import swath_edges  # noqa: E402
from uav_insar_planner.solver import rays  # noqa: E402
from uav_insar_planner.solver.power import station_radius_sq  # noqa: E402
from uav_insar_planner.solver.problem import make_problem  # noqa: E402
from uav_insar_planner.study.grid import MapRow  # noqa: E402
from uav_insar_planner.study.sweep import SweepRow  # noqa: E402
from uav_insar_planner.swarm import uav_color, uav_index  # noqa: E402

# Monte-Carlo panels, one per pair and the fused DEM: nine slaves' ten panels in two rows
HISTOGRAMS_PER_ROW = 5
SCHEME_STYLE = {
    "proposed": ("tab:blue", "o", "Proposed"),
    "single-baseline": ("tab:orange", "s", "Benchmark 1 (single-baseline)"),
    "fixed-master": ("tab:green", "^", "Benchmark 2 (fixed master)"),
    "static-power": ("tab:purple", "v", "Benchmark 3 (static power)"),
}


def plot_sweep(rows: Sequence[SweepRow], name: str, path: str | Path) -> None:
    """sigma_h per scheme against the swept value; the bound for the proposed scheme dashed;
    the band of sigma_h over the bound's minimisers shaded when present; values where a scheme
    is infeasible shaded red, as the paper's red region."""
    fig, ax = plt.subplots(figsize=(7, 4.5))
    schemes = list(dict.fromkeys(r.scheme for r in rows))
    values = sorted({r.value for r in rows})
    step = (values[1] - values[0]) / 2 if len(values) > 1 else 0.5
    for scheme in schemes:
        color, marker, label = SCHEME_STYLE.get(scheme, ("k", ".", scheme))
        pts = [r for r in rows if r.scheme == scheme]
        ok = [r for r in pts if r.feasible]
        ax.plot([r.value for r in ok], [r.sigma_h_m for r in ok], marker=marker, color=color,
                label=label + r": $\sigma_h$")
        if scheme == "proposed":
            ax.plot([r.value for r in ok], [r.sigma_h_bound_m for r in ok], "--", color=color,
                    label=label + r": bound $\overline{\sigma_h}$")
        band = [r for r in ok if np.isfinite(r.band_lo_m)]
        if band and scheme == "proposed":
            ax.plot([r.value for r in band], [r.bound_opt_m for r in band], ":", color=color,
                    label=label + ": least bound (paper's optimum)")
        if band:
            ax.fill_between([r.value for r in band], [r.band_lo_m for r in band],
                            [r.band_hi_m for r in band], color=color, alpha=0.15,
                            label=label + ": bound minimisers' $\\sigma_h$")
        for r in pts:
            if not r.feasible:
                ax.axvspan(r.value - step, r.value + step, color="red", alpha=0.08, lw=0)
                ax.plot([r.value], [ax.get_ylim()[0]], "x", color=color, ms=8)
    ax.set_xlabel(name)
    ax.set_ylabel("height error [m]")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title("Height error of the fused DEM (red: a scheme is infeasible)")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _cell_edges(values: Sequence[float]) -> np.ndarray:
    v = np.asarray(values, dtype=float)
    if len(v) == 1:
        return np.array([v[0] - 0.5, v[0] + 0.5])
    mid = (v[1:] + v[:-1]) / 2
    return np.concatenate([[2 * v[0] - mid[0]], mid, [2 * v[-1] - mid[-1]]])


def plot_map(rows: Sequence[MapRow], name1: str, name2: str, path: str | Path) -> None:
    """A heat map of sigma_h over (value1, value2) per scheme, one colour scale for all;
    cells where the scheme is infeasible red, as the paper's red region."""
    schemes = list(dict.fromkeys(r.point.scheme for r in rows))
    v1, v2 = sorted({r.value1 for r in rows}), sorted({r.value2 for r in rows})
    grids = {s: np.full((len(v2), len(v1)), np.nan) for s in schemes}
    for r in rows:
        if r.point.feasible:
            grids[r.point.scheme][v2.index(r.value2), v1.index(r.value1)] = r.point.sigma_h_m
    finite = np.concatenate([g[np.isfinite(g)] for g in grids.values()])
    norm = (matplotlib.colors.Normalize(finite.min(), finite.max()) if finite.size
            else matplotlib.colors.Normalize(0.0, 1.0))
    cmap = plt.get_cmap("viridis").copy()
    cmap.set_bad("tab:red")
    ncols = min(len(schemes), 2)
    nrows = -(-len(schemes) // ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(5.2 * ncols, 4 * nrows), squeeze=False,
                             layout="constrained")
    for ax, scheme in zip(axes.flat, schemes, strict=False):
        grid = grids[scheme]
        mesh = ax.pcolormesh(_cell_edges(v1), _cell_edges(v2), np.ma.masked_invalid(grid),
                             cmap=cmap, norm=norm)
        ax.set_title(f"{SCHEME_STYLE.get(scheme, (0, 0, scheme))[2]}: "
                     f"{int(np.isfinite(grid).sum())}/{grid.size} feasible", fontsize=9)
        ax.set_xlabel(name1)
        ax.set_ylabel(name2)
    for ax in list(axes.flat)[len(schemes):]:
        ax.set_visible(False)
    fig.colorbar(mesh, ax=axes, label=r"$\sigma_h$ [m] (red: infeasible)")
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _slave_region(p: Params, plan: Plan, k: int, xs: np.ndarray, zs: np.ndarray) -> np.ndarray:
    """Mask of the x-z grid where slave k alone meets C1, C3-C11 with the master at its plan.

    The feasible set is the ray model of solver/rays.py (the one the global back end searches),
    read at each grid point's look angle and slant range: the angle in the C3/C7 domain, the
    range inside the ray's C1/C5/C6/C8/C9-C11 limits and outside the master's C4 hole.
    """
    x, z = np.meshgrid(xs, zs)
    sc = make_problem(p, plan.scheme, plan.objective)
    r0 = float(model.slant_range(plan.formation[0, 0], plan.formation[0, 1], p.x_t))
    r = model.slant_range(x, z, p.x_t)
    th = model.look_angle(x, z, p.x_t)
    with np.errstate(divide="ignore", invalid="ignore"):
        lo, up = rays.ray_limits(sc, k, r0, th)
        h1, h2 = rays.master_hole(sc, r0, th)
    return ((th >= sc.th_lo) & (th <= sc.th_hi) & (r >= lo) & (r <= up)
            & ~((r > h1) & (r < h2)))


def plot_formation(p: Params, plan: Plan, path: str | Path) -> None:
    """The across-track plane: target line, the UAVs with their beams and swaths, the ground
    station with each UAV's communication disk (C9-C11), the master's C2 line and each slave's
    feasible region with the others at the plan."""
    flown = [k for k in range(plan.num_uavs) if np.isfinite(plan.formation[k, 0])]
    gx, _, gz = p.ground_station
    xs_all = [plan.formation[k, 0] for k in flown] + [p.x_t, gx]
    xlo, xhi = min(xs_all) - 40, max(xs_all) + 40
    zhi = max(max(plan.formation[k, 1] for k in flown), gz) + 30
    # equal axes: size the figure to the plane so the plot fills it; the legend (a row per
    # UAV, ten fit) sits to the right of the plane, off the drawing
    fig, ax = plt.subplots(figsize=(12.5, max(3.5, 10 * zhi / (xhi - xlo) + 1.2)))
    xs, zs = np.linspace(xlo, xhi, 400), np.linspace(0, zhi, 300)
    for k in flown:
        if k > 0:
            mask = _slave_region(p, plan, k, xs, zs)
            if mask.any():
                ax.contourf(xs, zs, mask.astype(float), levels=[0.5, 1.5], colors=[uav_color(k)],
                            alpha=0.15)
                ax.contour(xs, zs, mask.astype(float), levels=[0.5], colors=[uav_color(k)],
                           linewidths=0.8)
        rho2 = station_radius_sq(p, k, plan.scheme)
        if np.isfinite(rho2) and rho2 > 0:
            ax.add_patch(plt.Circle((gx, gz), np.sqrt(rho2), fill=False, ls=":",
                                    color=uav_color(k), lw=1))
    z_line = np.linspace(0, zhi, 2)
    ax.plot(model.master_x(z_line, p.x_t, p.theta0), z_line, "--", color=uav_color(0), lw=0.8,
            label=r"master line (C2, $\theta_0$)")
    for k in flown:
        x, z = plan.formation[k]
        th = p.theta0 if k == 0 else float(model.look_angle(x, z, p.x_t))
        edges = swath_edges(x, z, th, p.beamwidth)
        for edge in edges:
            ax.plot([x, edge], [z, 0], color=uav_color(k), lw=0.6, alpha=0.6)
        ax.plot(edges, [0, 0], color=uav_color(k), lw=4, alpha=0.35)
        ax.plot([x], [z], "o", color=uav_color(k), ms=8,
                label=f"U{k} {'master' if k == 0 else 'slave'} ({x:.1f}, {z:.1f}) m")
    ax.plot([p.x_t], [0], "k*", ms=12, label=f"target line x_t = {p.x_t:g} m")
    ax.plot([gx], [gz], "ks", ms=8, label="ground station (x-z projection)")
    ax.set_xlim(xlo, xhi)
    ax.set_ylim(0, zhi)
    ax.set_aspect("equal")
    ax.set_xlabel("x (range / across-track) [m]")
    ax.set_ylabel("z (altitude) [m]")
    ax.set_title(f"{plan.scheme}: sigma_h = {plan.sigma_h_m:.4f} m  (shaded: slave feasible "
                 "regions; dotted: C9-C11 disks; thick: swaths)", fontsize=9)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
    ax.grid(True, alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_montecarlo(result: dict, path: str | Path) -> None:
    """Height-error histograms of a Monte-Carlo run (montecarlo.simulate with keep_samples),
    one panel per pair and the fused DEM, each against the model's Gaussian N(0, sigma_h^2)
    (eq. 13 with the Cramer-Rao phase error; eq. 15 for the fused)."""
    errs = result["height_errors_m"]
    rows = {**result["pairs"], **({"fused": result["fused"]} if "fused" in result else {})}
    cols = min(len(rows), HISTOGRAMS_PER_ROW)
    grid = -(-len(rows) // cols)
    fig, axes = plt.subplots(grid, cols, figsize=(4.2 * cols, 3.6 * grid), squeeze=False)
    for ax in axes.flat[len(rows):]:
        ax.set_visible(False)
    for ax, (name, row) in zip(axes.flat, rows.items(), strict=False):
        e = errs[name]
        s_model, s_mc = row["sigma_h_model_m"], row["sigma_h_mc_m"]["value"]
        lim = 4.0 * max(s_model, s_mc)
        ax.hist(e, bins=120, range=(-lim, lim), density=True, color="tab:blue", alpha=0.6,
                label=f"Monte-Carlo, std {s_mc:.4f} m")
        x = np.linspace(-lim, lim, 400)
        ax.plot(x, np.exp(-0.5 * (x / s_model) ** 2) / (s_model * np.sqrt(2 * np.pi)), "k--",
                label=f"model Gaussian, {s_model:.4f} m")
        ax.set_title("fused DEM" if name == "fused" else f"pair U0-U{uav_index(name)}", fontsize=10)
        ax.set_xlabel("height error [m]")
        ax.legend(fontsize=7)
        ax.grid(True, alpha=0.3)
    for ax in axes[:, 0]:
        ax.set_ylabel("density [1/m]")
    fig.suptitle(f"{result['samples']} samples per pair, n_L = {result['looks']}, "
                 f"seed {result['seed']}", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
