"""The survey's map (`uav-insar survey`): the area, each strip's swath and master track
(coloured by sortie, an arrow for the direction of flight and a dot at its run-in's entry),
the home and the ground station, in metres east and north of the home; and the accuracy-time
front of `--front`: the certified sigma_h against v_y, with the speed chosen.

Drawn with matplotlib's Agg back end (as figures.py), so it works without a screen.
"""
from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from uav_insar_planner.survey.planning import FrontRow, SurveyPlan  # noqa: E402
from uav_insar_planner.track.frame import TrackFrame  # noqa: E402


def plot_survey(survey: SurveyPlan, path: str | Path) -> None:
    """The map of `survey` into `path` (PNG, or any type matplotlib saves)."""
    fig, ax = plt.subplots(figsize=(8, 8))
    ring = np.array(survey.area.ring_ne + (survey.area.ring_ne[0],))
    ax.fill(ring[:, 1], ring[:, 0], color="0.85", zorder=0, label="area")
    colors = plt.get_cmap("tab10")
    sortie_of = {i: s for s, sortie in enumerate(survey.sorties) for i in sortie.strips}
    for sp in survey.strips:
        s = sp.strip
        color = colors(sortie_of[s.index] % 10)
        swath = np.array(s.swath_ne() + (s.swath_ne()[0],))
        ax.fill(swath[:, 1], swath[:, 0], color=color, alpha=0.18, zorder=1)
        (n0, e0), (n1, e1) = s.master_line_ne()
        ax.annotate("", xy=(e1, n1), xytext=(e0, n0), zorder=3,
                    arrowprops={"arrowstyle": "->", "color": color, "lw": 1.5})
        entry = TrackFrame(s.bearing_rad).to_ned(*s.track.entry, 0.0)
        ax.plot([entry[1], e0], [entry[0], n0], ":", color=color, lw=1, zorder=2)
        ax.plot(entry[1], entry[0], ".", color=color, zorder=3)
    for s, sortie in enumerate(survey.sorties):
        ax.plot([], [], color=colors(s % 10), label=f"sortie {s + 1}: strips "
                f"{sortie.strips[0]}-{sortie.strips[-1]}, {sortie.flight_time_s / 60:.1f} min")
    ax.plot(0.0, 0.0, "k^", ms=9, label="home")
    station = survey.options.station_ne_m
    ax.plot(station[1], station[0], "ks", ms=7, label="ground station")
    ax.set_aspect("equal")
    ax.set_xlabel("east of home [m]")
    ax.set_ylabel("north of home [m]")
    ax.set_title(f"{len(survey.strips)} strips at {survey.speed_mps:.2f} m/s, swath "
                 f"{survey.swath_m:.1f} m, sigma_h {survey.plan.sigma_h_m:.4f} m; "
                 f"{survey.covered_fraction:.1%} covered", fontsize=10)
    ax.legend(loc="best", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_front(rows: Sequence[FrontRow], chosen_mps: float, path: str | Path) -> None:
    """The accuracy-time front: the certified sigma_h (and its lower bound) against the
    survey's flight time, each point labelled with its v_y; the chosen speed marked."""
    ok = [r for r in rows if np.isfinite(r.sigma_h_m) and np.isfinite(r.total_time_s)]
    fig, ax = plt.subplots(figsize=(7, 4.5))
    minutes = [r.total_time_s / 60.0 for r in ok]
    ax.plot(minutes, [r.sigma_h_m for r in ok], "o-", label="sigma_h (certified plan)")
    ax.plot(minutes, [r.lower_bound_m for r in ok], "v--", ms=4, label="its lower bound")
    for r, m in zip(ok, minutes, strict=True):
        ax.annotate(f"{r.speed_mps:.2f}", (m, r.sigma_h_m), fontsize=7,
                    textcoords="offset points", xytext=(3, 3))
        if abs(r.speed_mps - chosen_mps) < 1e-9:
            ax.plot(m, r.sigma_h_m, "o", color="tab:red", ms=9, zorder=0,
                    label=f"chosen: {chosen_mps:.2f} m/s")
    ax.set_xlabel("flight time of the survey [min] (labels: v_y in m/s)")
    ax.set_ylabel("sigma_h [m]")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
