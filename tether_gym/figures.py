"""The paper's figures, recomputed from the public physics API: `python -m tether_gym.figures`.

Each figure is a pair of functions: one computes its data as tables (column name -> 1-D array,
angles in radians) without drawing, so tests can check the numbers against the paper's claims;
the other draws them (degrees on the axes). The command writes NAME.png and the tables as CSV
beside it (NAME.csv, or NAME_TABLE.csv for a figure with several tables), optionally NAME.svg.
The CSVs are written with a fixed number format and the images without time stamps, so a second
run with the same arguments writes the same bytes.

The sweeps use the impulse model (the paper's sec. 4), Figs. 4 and 9 compare it with the hybrid
one, the trajectory pictures come from `physics.trajectory` (hybrid model).
"""

from __future__ import annotations

import math
import os
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import matplotlib
import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.patches import Circle
from tqdm import tqdm

from tether_gym.arguments import ArgumentParser
from tether_gym.physics import (
    bounce,
    deadspin_offset_angles,
    geometry,
    max_deceleration_offset_angles,
    perpendicular_speed,
    stiffness_from_rho,
)
from tether_gym.physics.geometry import initial_state
from tether_gym.physics.trajectory import trajectory

Table = dict[str, np.ndarray]

BANK_SHOT = math.pi / 4
"""The 45 degree tether of Figs. 4 and 6a-c."""
INLINE = math.pi / 2
"""The tether anchored directly behind the puck (Figs. 6d-f)."""
DISK, RING = 0.5, 1.0
"""I / (m R^2) of a solid disk and of a thin ring."""
FIGURE_MASS, FIGURE_TETHER_LENGTH = 1.0, 10.0
"""The figures' nondimensional puck: mass (kg) and tether rest length (m) where a model needs
them; with `bounce`'s defaults R = 1 m and launch speed 1 m/s, a spin in rad/s reads as w R / v."""
DPI = 110


# --- data --------------------------------------------------------------------------------


def rho_convergence(rho: np.ndarray | None = None, tether_angle: float = BANK_SHOT) -> Table:
    """Fig. 4: deflection of the centre-of-mass tether against rho, impulse and hybrid."""
    rho = np.logspace(0.0, 4.0, 161) if rho is None else np.asarray(rho, dtype=np.float64)
    v_theta = perpendicular_speed(tether_angle, 0.0, offset=0.0)
    stiffness = stiffness_from_rho(rho, FIGURE_MASS, FIGURE_TETHER_LENGTH, v_theta)
    common = {"offset": 0.0, "mass": FIGURE_MASS, "tether_length": FIGURE_TETHER_LENGTH}
    hybrid = bounce(tether_angle, 0.0, model="hybrid", stiffness=stiffness, **common)
    impulse = bounce(tether_angle, np.zeros_like(rho), **common)
    return {
        "rho": rho,
        "impulse_deflection": impulse.deflection,
        "hybrid_deflection": np.where(hybrid.completed, hybrid.deflection, np.nan),
        "hybrid_speed_ratio": hybrid.speed_ratio,
    }


def _sweep(tether_angle: float, inertia_ratios: Sequence[float], points: int) -> Table:
    """Impulse bounces over a half-circle sweep of the offset angle, one block per puck."""
    kappa = np.repeat(np.asarray(inertia_ratios, dtype=np.float64), points)
    alpha = np.tile(np.linspace(0.0, math.pi, points), len(inertia_ratios))
    result = bounce(tether_angle, alpha, inertia_ratio=kappa)
    return {
        "inertia_ratio": kappa,
        "offset_angle": alpha,
        "deflection": result.deflection,
        "speed_ratio": result.speed_ratio,
        "velocity_x": result.velocity[:, 0],
        "velocity_y": result.velocity[:, 1],
        "spin": result.spin,
    }


def offset_sweep(
    inertia_ratios: Sequence[float] = (DISK, RING), points: int = 361
) -> dict[str, Table]:
    """Fig. 6a-b: the 45 degree tether, offset angle swept over [0, pi], and the marked points:
    maximum deflection (alpha = 0, pi), minimum deflection (pi/2), maximum deceleration (the
    closed form of `max_deceleration_offset_angles`)."""
    kinds, kappas, alphas = [], [], []
    for kappa in inertia_ratios:
        low, high = max_deceleration_offset_angles(kappa)
        for kind, alpha in [
            ("max_deflection", 0.0),
            ("max_deflection", math.pi),
            ("min_deflection", math.pi / 2),
            ("max_deceleration", float(low)),
            ("max_deceleration", float(high)),
        ]:
            kinds.append(kind)
            kappas.append(kappa)
            alphas.append(alpha)
    marked = bounce(BANK_SHOT, np.array(alphas), inertia_ratio=np.array(kappas))
    return {
        "data": _sweep(BANK_SHOT, inertia_ratios, points),
        "points": {
            "kind": np.array(kinds),
            "inertia_ratio": np.array(kappas),
            "offset_angle": np.array(alphas),
            "deflection": marked.deflection,
            "speed_ratio": marked.speed_ratio,
        },
    }


def _argmin_halves(alpha: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Offset angle of the least value in [0, pi/2] and in [pi/2, pi], for each row."""
    half = alpha.size // 2
    return alpha[np.argmin(values[:, : half + 1], axis=1)], alpha[
        half + np.argmin(values[:, half:], axis=1)
    ]


def critical_locus(inertia_ratio: np.ndarray | None = None, points: int = 1441) -> Table:
    """Figs. 6c and 6f: the maximum-deceleration points of the 45 degree tether and the deadspin
    points of the inline tether against I / (m R^2), in closed form and found by brute force
    (the least post-bounce speed on an offset-angle grid, on each side of pi/2). A deadspin
    exists where some offset angle lets the puck carry on: the most forward post-bounce
    velocity of the inline tether is >= 0."""
    kappa = np.linspace(0.02, 2.0, 100) if inertia_ratio is None else np.asarray(inertia_ratio)
    alpha = np.linspace(0.0, math.pi, points)
    table = {"inertia_ratio": kappa}
    table["max_deceleration_low"], table["max_deceleration_high"] = max_deceleration_offset_angles(
        kappa
    )
    table["deadspin_low"], table["deadspin_high"] = deadspin_offset_angles(kappa)
    sweeps = {
        name: bounce(beta, alpha, inertia_ratio=kappa[:, None])
        for name, beta in [("bank", BANK_SHOT), ("inline", INLINE)]
    }
    for name, result in sweeps.items():
        speed = result.speed_ratio
        table[f"{name}_slowest_low"], table[f"{name}_slowest_high"] = _argmin_halves(alpha, speed)
        table[f"{name}_least_speed_ratio"] = speed.min(axis=1)
    table["inline_most_forward_velocity"] = sweeps["inline"].velocity[..., 1].max(axis=1)
    return table


def inline_sweep(
    inertia_ratios: Sequence[float] = (DISK, RING), points: int = 361
) -> dict[str, Table]:
    """Figs. 6d-e: the inline tether over the offset angle, and the deadspin points bounding
    the carry-on region (closed form)."""
    low, high = deadspin_offset_angles(np.asarray(inertia_ratios))
    return {
        "data": _sweep(INLINE, inertia_ratios, points),
        "points": {
            "inertia_ratio": np.asarray(inertia_ratios, dtype=np.float64),
            "deadspin_low": low,
            "deadspin_high": high,
        },
    }


def radius_of_gyration(inertia_ratio: float = DISK, tether_angle: float = INLINE) -> Table:
    """Fig. 7: the set-up of greatest deceleration drawn to scale (R = 1, centre of mass at the
    origin): the attachment point on the rim, the foot of the perpendicular from the centre of
    mass to the tether's line of action, and the radius of gyration sqrt(I / m)."""
    alpha = float(max_deceleration_offset_angles(inertia_ratio)[0])
    _, _, _, _, rx, ry, _ = initial_state(
        tether_angle, alpha, 1.0, 1.0, FIGURE_TETHER_LENGTH, 1.0, 0.0
    )
    u = np.array([math.cos(tether_angle), math.sin(tether_angle)])
    attachment = np.array([rx, ry])
    foot = attachment - (attachment @ u) * u
    anchorward = attachment - 2.5 * u
    return {
        "point": np.array(["centre_of_mass", "attachment", "foot", "towards_anchor"]),
        "x": np.array([0.0, attachment[0], foot[0], anchorward[0]]),
        "y": np.array([0.0, attachment[1], foot[1], anchorward[1]]),
        "radius": np.full(4, 1.0),
        "radius_of_gyration": np.full(4, math.sqrt(inertia_ratio)),
        "offset_angle": np.full(4, alpha),
    }


def tether_angle_sweep(
    restitutions: Sequence[float] = (1.0, 0.9, 0.75, 0.5), points: int = 91
) -> Table:
    """Fig. 8: deflection against the tether angle on the centre of mass, for several
    coefficients of restitution, beside the 2:1 line."""
    e = np.repeat(np.asarray(restitutions, dtype=np.float64), points)
    beta = np.tile(np.linspace(0.0, math.pi / 2, points), len(restitutions))
    result = bounce(beta, 0.0, offset=0.0, restitution=e)
    return {
        "restitution": e,
        "tether_angle": beta,
        "deflection": result.deflection,
        "two_to_one": 2.0 * beta,
    }


EXPERIMENT_RHO = 850.0
"""The paper's experimental system has rho > 850 (sec. 3.3)."""
FIG9_RESTITUTION = 0.9
"""A light string tether that returns most of its stretch energy: it loses 1 - e^2 = 19% of the
energy of the motion along it and brings the 45 degree bank shot about 3 degrees short of 90: a
small shortfall like the "small negative error" the paper reports for Fig. 8."""
FIG9_SPIN = 0.1
"""Pre-bounce spin w R / v (rad/s for the figures' puck). A pendulum hammer striking b off the
centre line spins a solid disk at w = v b / (kappa R^2), w R / v = b / (kappa R): 0.1 for
b = 5% of R, i.e. 2.5 rad/s for a 4 cm air-hockey puck launched at 1 m/s."""
FIG9_CURVES = {
    "ideal": ("impulse", 1.0, 0.0),
    "elastic": ("hybrid", 1.0, 0.0),
    "dissipative": ("hybrid", FIG9_RESTITUTION, 0.0),
    "dissipative_spin_ccw": ("hybrid", FIG9_RESTITUTION, FIG9_SPIN),
    "dissipative_spin_cw": ("hybrid", FIG9_RESTITUTION, -FIG9_SPIN),
}
"""Fig. 9's curves: name -> (model, restitution, pre-bounce spin)."""


def offset_sweep_dissipation(points: int = 181) -> Table:
    """Fig. 9: the 45 degree tether on a solid disk's rim, offset angle swept over [0, pi]: the
    impulse model's ideal deflection (e = 1, no spin) beside the hybrid model of the paper's
    experiment (rho >= 850) with and without the two sources of error its sec. 5 names,
    dissipation in the tether (`FIG9_RESTITUTION`) and a small pre-bounce spin from the
    pendulum hammer (`FIG9_SPIN`, either sense). One tether: its stiffness gives rho = 850 where
    the attachment point crosses the tether fastest, so rho >= 850 on every row (inf for the
    impulse model, its limit). alpha is the offset angle at tautening, as the paper plots the
    deflection against the angle measured at the bounce."""
    alpha = np.linspace(0.0, math.pi, points)
    spins = np.array([spin for _, _, spin in FIG9_CURVES.values()])
    fastest = perpendicular_speed(BANK_SHOT, alpha[:, None], spin=spins).max()
    stiffness = float(
        stiffness_from_rho(EXPERIMENT_RHO, FIGURE_MASS, FIGURE_TETHER_LENGTH, fastest)
    )
    blocks = []
    for name, (model, e, spin) in FIG9_CURVES.items():
        hybrid = model == "hybrid"
        result = bounce(
            BANK_SHOT,
            alpha,
            inertia_ratio=DISK,
            spin=spin,
            restitution=e,
            model=model,
            mass=FIGURE_MASS,
            tether_length=FIGURE_TETHER_LENGTH,
            stiffness=stiffness if hybrid else None,
        )
        v_theta = perpendicular_speed(BANK_SHOT, alpha, spin=spin)
        rho = geometry.rho(stiffness, FIGURE_MASS, FIGURE_TETHER_LENGTH, v_theta)
        blocks.append(
            {
                "curve": np.full(points, name),
                "model": np.full(points, model),
                "restitution": np.full(points, e),
                "spin": np.full(points, spin),
                "rho": rho if hybrid else np.full(points, math.inf),
                "offset_angle": alpha,
                "deflection": np.where(result.completed, result.deflection, np.nan),
                "speed_ratio": result.speed_ratio,
            }
        )
    return {key: np.concatenate([b[key] for b in blocks]) for key in blocks[0]}


TRAJECTORIES = {
    "bank_shot": (BANK_SHOT, 0.0),
    "outboard_shallow": (BANK_SHOT, math.pi / 2),
    "deadspin": (INLINE, math.asin(math.sqrt(DISK))),
}
"""Figs. 1, 5 and 10: name -> (tether angle, offset angle) of a solid disk on the rim."""
TRAJECTORY_SPAN = 6.0
"""Seconds of free flight shown on each side of the contact (R = 1 m, launch speed 1 m/s)."""


def trajectories(frames: int = 7) -> Table:
    """The hybrid model's bounces of `TRAJECTORIES` (tether 5 R long), one block per set-up."""
    blocks = []
    for name, (beta, alpha) in TRAJECTORIES.items():
        traj = trajectory(
            beta,
            alpha,
            tether_length=5.0,
            before=TRAJECTORY_SPAN,
            after=TRAJECTORY_SPAN,
            frames=frames,
        )
        blocks.append(
            {
                "setup": np.full(traj.t.size, name),
                "t": traj.t,
                "com_x": traj.com[:, 0],
                "com_y": traj.com[:, 1],
                "orientation": traj.orientation,
                "attachment_x": traj.attachment[:, 0],
                "attachment_y": traj.attachment[:, 1],
                "taut": traj.taut,
            }
        )
    return {key: np.concatenate([b[key] for b in blocks]) for key in blocks[0]}


# --- drawing -----------------------------------------------------------------------------


def _figure(width: float, height: float) -> Figure:
    """A figure drawn off-screen by Agg, without pyplot's global state."""
    figure = Figure(figsize=(width, height), dpi=DPI, layout="constrained")
    FigureCanvasAgg(figure)
    return figure


def _block(table: Table, key: str, value) -> Table:
    """The rows of a long table where `key` equals `value`."""
    rows = table[key] == value
    return {name: column[rows] for name, column in table.items()}


PUCKS = {DISK: "solid disk", RING: "ring"}
MARKS = {"max_deflection": "o", "min_deflection": "s", "max_deceleration": "D"}


def draw_rho_convergence(data: dict[str, Table]) -> Figure:
    table = data["data"]
    figure = _figure(9.0, 3.6)
    left, right = figure.subplots(1, 2)
    left.semilogx(table["rho"], np.degrees(table["impulse_deflection"]), "k--", label="impulse")
    left.semilogx(table["rho"], np.degrees(table["hybrid_deflection"]), "C0", label="hybrid")
    error = np.abs(table["hybrid_deflection"] - table["impulse_deflection"])
    right.loglog(table["rho"], np.degrees(error), "C0")
    for ax in (left, right):
        ax.axvspan(100.0, table["rho"][-1], color="C2", alpha=0.15, label="converged, rho > 100")
        ax.set_xlabel("rho = sqrt(k/m) L / v_theta")
        ax.grid(True, which="both", alpha=0.3)
    left.set_ylabel("post-bounce direction (deg)")
    left.set_title("Fig. 4: 45 deg tether on the centre of mass")
    left.legend()
    right.set_ylabel("|hybrid - impulse| (deg)")
    right.set_title("distance from the impulse model")
    return figure


def draw_offset_sweep(data: dict[str, Table]) -> Figure:
    sweep, points = data["data"], data["points"]
    figure = _figure(12.0, 4.0)
    deflection_ax, speed_ax = figure.add_subplot(1, 3, 1), figure.add_subplot(1, 3, 2)
    polar = figure.add_subplot(1, 3, 3, projection="polar")
    polar.set_theta_zero_location("N")
    for i, (kappa, label) in enumerate(PUCKS.items()):
        curve, marked = (
            _block(sweep, "inertia_ratio", kappa),
            _block(points, "inertia_ratio", kappa),
        )
        alpha = np.degrees(curve["offset_angle"])
        deflection_ax.plot(alpha, np.degrees(curve["deflection"]), f"C{i}", label=label)
        speed_ax.plot(alpha, curve["speed_ratio"], f"C{i}", label=label)
        polar.plot(curve["deflection"], curve["speed_ratio"], f"C{i}", label=label)
        for kind, marker in MARKS.items():
            rows = marked["kind"] == kind
            style = {"color": f"C{i}", "marker": marker, "linestyle": "none", "markersize": 7}
            name = kind.replace("_", " ") if i == 0 else None
            deflection_ax.plot(
                np.degrees(marked["offset_angle"][rows]),
                np.degrees(marked["deflection"][rows]),
                **style,
                label=name,
            )
            speed_ax.plot(
                np.degrees(marked["offset_angle"][rows]), marked["speed_ratio"][rows], **style
            )
            polar.plot(marked["deflection"][rows], marked["speed_ratio"][rows], **style)
    for ax in (deflection_ax, speed_ax):
        ax.set_xlabel("offset angle alpha (deg)")
        ax.set_xticks(range(0, 181, 45))
        ax.grid(True, alpha=0.3)
    deflection_ax.set_ylabel("deflection (deg)")
    deflection_ax.set_title("Fig. 6a-b: 45 deg tether, rim attachment")
    deflection_ax.legend(fontsize=8)
    speed_ax.set_ylabel("post-bounce speed / launch speed")
    speed_ax.set_title("relative speed")
    polar.set_title("post-bounce velocity (launch along 0 deg)")
    polar.set_thetalim(0.0, math.pi * 0.6)
    polar.set_rlim(0.0, 1.05)
    return figure


def draw_critical_locus(data: dict[str, Table]) -> Figure:
    table = data["data"]
    kappa = table["inertia_ratio"]
    figure = _figure(10.0, 4.0)
    axes = figure.subplots(1, 2, sharey=True)
    panels = [
        ("Fig. 6c: maximum deceleration, 45 deg tether", "max_deceleration", "bank"),
        ("Fig. 6f: deadspin, inline tether", "deadspin", "inline"),
    ]
    for ax, (title, closed, brute) in zip(axes, panels, strict=True):
        for side in ("low", "high"):
            ax.plot(kappa, np.degrees(table[f"{closed}_{side}"]), "C0", label=None)
            found = np.degrees(table[f"{brute}_slowest_{side}"])
            if brute == "inline":  # beyond the merge the slowest bounce still rebounds
                found = np.where(table["inline_most_forward_velocity"] >= -1e-9, found, np.nan)
            ax.plot(kappa[::3], found[::3], "C1.", markersize=5)
        ax.plot([], [], "C0", label="closed form: sin^2(alpha) = I/(m R^2)")
        ax.plot([], [], "C1.", label="least speed on an alpha grid")
        ax.axvline(1.0, color="k", linestyle=":", label="I = m R^2 (ring)")
        ax.set_xlabel("I / (m R^2)")
        ax.set_title(title, fontsize=10)
        ax.set_yticks(range(0, 181, 45))
        ax.grid(True, alpha=0.3)
    axes[0].set_ylabel("offset angle alpha (deg)")
    axes[1].legend(fontsize=8, loc="lower left")
    return figure


def draw_inline_sweep(data: dict[str, Table]) -> Figure:
    sweep, points = data["data"], data["points"]
    figure = _figure(10.0, 4.0)
    axes = figure.subplots(1, 2, sharey=True)
    for ax, (kappa, label), low, high in zip(
        axes, PUCKS.items(), points["deadspin_low"], points["deadspin_high"], strict=True
    ):
        curve = _block(sweep, "inertia_ratio", kappa)
        alpha = np.degrees(curve["offset_angle"])
        ax.plot(alpha, curve["velocity_y"], "C0", label="post-bounce velocity / launch speed")
        ax.plot(alpha, curve["spin"], "C1--", label="post-bounce spin x R / launch speed")
        ax.axhline(0.0, color="k", linewidth=0.8)
        low_deg, high_deg = np.degrees([low, high])
        ax.axvspan(0.0, low_deg, color="C3", alpha=0.12, label="rebound")
        ax.axvspan(high_deg, 180.0, color="C3", alpha=0.12)
        ax.axvspan(low_deg, high_deg, color="C2", alpha=0.2, label="carry on")
        ax.plot(np.degrees([low, high]), [0.0, 0.0], "ko", label="deadspin")
        ax.set_title(f"Fig. 6{'d' if kappa == DISK else 'e'}: inline tether, {label}")
        ax.set_xlabel("offset angle alpha (deg)")
        ax.set_xticks(range(0, 181, 45))
        ax.set_xlim(0.0, 180.0)
        ax.grid(True, alpha=0.3)
    axes[0].set_ylabel("along the launch direction")
    figure.legend(*axes[0].get_legend_handles_labels(), loc="outside lower center", ncols=5)
    return figure


def draw_radius_of_gyration(data: dict[str, Table]) -> Figure:
    table = data["data"]
    point = {
        name: (x, y) for name, x, y in zip(table["point"], table["x"], table["y"], strict=True)
    }
    gyration = table["radius_of_gyration"][0]
    figure = _figure(5.0, 5.0)
    ax = figure.subplots()
    ax.add_patch(Circle((0.0, 0.0), 1.0, facecolor="0.9", edgecolor="k", label="puck (disk)"))
    ax.add_patch(
        Circle(
            (0.0, 0.0),
            gyration,
            fill=False,
            linestyle="--",
            edgecolor="C0",
            label=f"radius of gyration sqrt(I/m) = {gyration:.3f} R",
        )
    )
    (ax_, ay_), (fx, fy), (tx, ty) = point["attachment"], point["foot"], point["towards_anchor"]
    ax.plot([2 * ax_ - tx, tx], [2 * ay_ - ty, ty], "C3:", label="line of action")
    ax.plot([ax_, tx], [ay_, ty], "C3", linewidth=2.5, label="tether (to the anchor)")
    ax.plot([0.0, fx], [0.0, fy], "C0", label="moment arm")
    ax.plot([0.0, ax_], [0.0, ay_], "k", linewidth=1)
    ax.plot(0.0, 0.0, "k+", markersize=12)
    ax.plot(ax_, ay_, "C3o")
    alpha = math.degrees(table["offset_angle"][0])
    ax.set_title(
        f"Fig. 7: tangent to the radius of gyration (alpha = {alpha:.0f} deg)", fontsize=10
    )
    ax.set_aspect("equal")
    ax.set_xlim(-1.6, 1.6)
    ax.set_ylim(-2.8, 1.4)
    ax.legend(fontsize=7, loc="lower right")
    ax.set_xlabel("x / R")
    ax.set_ylabel("y / R")
    return figure


def draw_tether_angle_sweep(data: dict[str, Table]) -> Figure:
    table = data["data"]
    figure = _figure(5.5, 4.5)
    ax = figure.subplots()
    first = _block(table, "restitution", table["restitution"][0])
    ax.plot(
        np.degrees(first["tether_angle"]),
        np.degrees(first["two_to_one"]),
        "k:",
        lw=3,
        label="2:1 line",
    )
    for i, e in enumerate(np.unique(table["restitution"])[::-1]):
        curve = _block(table, "restitution", e)
        ax.plot(
            np.degrees(curve["tether_angle"]),
            np.degrees(curve["deflection"]),
            f"C{i}",
            label=f"e = {e:g}",
        )
    ax.set_xlabel("tether angle beta (deg)")
    ax.set_ylabel("deflection (deg)")
    ax.set_xticks(range(0, 91, 15))
    ax.set_yticks(range(0, 181, 30))
    ax.set_title("Fig. 8: tether on the centre of mass", fontsize=10)
    ax.grid(True, alpha=0.3)
    ax.legend()
    return figure


FIG9_STYLES = {
    "ideal": ("k--", "impulse model, e = 1, no spin (ideal)"),
    "elastic": ("C0", f"hybrid, rho >= {EXPERIMENT_RHO:g}, e = 1, no spin"),
    "dissipative": ("C3", f"hybrid, e = {FIG9_RESTITUTION:g}, no spin"),
    "dissipative_spin_ccw": (
        "C1-.",
        f"hybrid, e = {FIG9_RESTITUTION:g}, spin +{FIG9_SPIN:g} v/R (ccw)",
    ),
    "dissipative_spin_cw": (
        "C2:",
        f"hybrid, e = {FIG9_RESTITUTION:g}, spin -{FIG9_SPIN:g} v/R (cw)",
    ),
}
"""Fig. 9's line style and legend label of each curve."""


def draw_offset_sweep_dissipation(data: dict[str, Table]) -> Figure:
    table = data["data"]
    figure = _figure(11.0, 4.2)
    deflection_ax, error_ax = figure.subplots(1, 2)
    ideal = _block(table, "curve", "ideal")["deflection"]
    for name, (style, label) in FIG9_STYLES.items():
        curve = _block(table, "curve", name)
        alpha = np.degrees(curve["offset_angle"])
        deflection_ax.plot(alpha, np.degrees(curve["deflection"]), style, label=label)
        error_ax.plot(alpha, np.degrees(curve["deflection"] - ideal), style, label=label)
    for ax in (deflection_ax, error_ax):
        ax.set_xlabel("offset angle alpha (deg)")
        ax.set_xticks(range(0, 181, 45))
        ax.set_xlim(0.0, 180.0)
        ax.grid(True, alpha=0.3)
    deflection_ax.set_ylabel("deflection (deg)")
    deflection_ax.set_title("Fig. 9: 45 deg tether, solid disk, rim attachment", fontsize=10)
    error_ax.set_ylabel("deflection - ideal (deg)")
    error_ax.set_title("what dissipation and pre-bounce spin change", fontsize=10)
    figure.legend(
        *deflection_ax.get_legend_handles_labels(), loc="outside lower center", ncols=3, fontsize=8
    )
    return figure


def draw_trajectories(data: dict[str, Table]) -> Figure:
    table = data["data"]
    figure = _figure(12.0, 4.6)
    axes = figure.subplots(1, len(TRAJECTORIES))
    titles = {
        "bank_shot": "Figs. 1, 5a: bank shot, 45 deg tether, alpha = 0",
        "outboard_shallow": "Fig. 5b: 45 deg tether, alpha = 90 deg: shallower",
        "deadspin": "Fig. 10: inline tether at the radius of gyration",
    }
    for ax, name in zip(axes, TRAJECTORIES, strict=True):
        run = _block(table, "setup", name)
        t, x, y = run["t"], run["com_x"], run["com_y"]
        px, py = run["attachment_x"], run["attachment_y"]
        ax.plot(x, y, "C0", linewidth=1, label="centre of mass")
        contact = t[run["taut"]]
        outside = (t <= contact[0]) | (t >= contact[-1])
        for i in np.flatnonzero(outside):
            ax.add_patch(Circle((x[i], y[i]), 1.0, fill=False, edgecolor="0.4", linewidth=0.8))
            ax.plot([x[i], px[i]], [y[i], py[i]], "C1", linewidth=1.2)
        for i, style in [(0, "C3:"), (np.flatnonzero(t == 0.0)[0], "C3-"), (-1, "C3:")]:
            ax.plot([0.0, px[i]], [0.0, py[i]], style, linewidth=1)
        ax.plot([], [], "C1", label="centre of mass -> attachment point")
        ax.plot([], [], "C3-", label="tether taut (dotted: slack)")
        ax.plot(0.0, 0.0, "kx", markersize=8, label="anchor")
        ax.set_aspect("equal")
        ax.set_title(titles[name], fontsize=9)
        ax.grid(True, alpha=0.3)
    axes[0].legend(fontsize=7, loc="lower left")
    return figure


# --- the command -------------------------------------------------------------------------


@dataclass(frozen=True)
class FigureSpec:
    """One figure: its name, its data (tables by name) and how to draw them."""

    name: str
    compute: Callable[[], dict[str, Table]]
    draw: Callable[[dict[str, Table]], Figure]
    tables: tuple[str, ...] = ("data",)

    def csv_name(self, table: str) -> str:
        """NAME.csv for the main table, NAME_TABLE.csv for the others."""
        return f"{self.name}.csv" if table == "data" else f"{self.name}_{table}.csv"

    def files(self, svg: bool) -> list[str]:
        """The files this figure writes."""
        csv = [self.csv_name(table) for table in self.tables]
        return [f"{self.name}.png", *csv, *([f"{self.name}.svg"] if svg else [])]


def _single(function: Callable[[], Table]) -> Callable[[], dict[str, Table]]:
    return lambda: {"data": function()}


FIGURES = {
    spec.name: spec
    for spec in [
        FigureSpec("fig4_rho_convergence", _single(rho_convergence), draw_rho_convergence),
        FigureSpec("fig6ab_offset_sweep", offset_sweep, draw_offset_sweep, ("data", "points")),
        FigureSpec("fig6cf_critical_locus", _single(critical_locus), draw_critical_locus),
        FigureSpec("fig6de_inline_tether", inline_sweep, draw_inline_sweep, ("data", "points")),
        FigureSpec("fig7_radius_of_gyration", _single(radius_of_gyration), draw_radius_of_gyration),
        FigureSpec("fig8_tether_angle", _single(tether_angle_sweep), draw_tether_angle_sweep),
        FigureSpec(
            "fig9_offset_sweep_dissipation",
            _single(offset_sweep_dissipation),
            draw_offset_sweep_dissipation,
        ),
        FigureSpec("trajectories", _single(trajectories), draw_trajectories),
    ]
}


def _cell(value) -> str:
    """One CSV cell in a fixed format, so identical data give identical bytes."""
    if isinstance(value, (str, np.str_)):
        return str(value)
    if isinstance(value, (bool, np.bool_)):
        return str(int(value))
    return f"{float(value):.10g}"


def write_csv(path: Path, table: Table) -> None:
    """`table` as CSV: a header of column names, then one row per index."""
    rows = [",".join(table)]
    rows += [",".join(map(_cell, row)) for row in zip(*table.values(), strict=True)]
    path.write_text("\n".join(rows) + "\n")


def check_output(out: Path, files: Sequence[str], overwrite: bool) -> None:
    """Make sure `out` is a writable folder and holds none of `files` unless `overwrite`;
    raise ValueError with the reason otherwise. Called before any computation."""
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise ValueError(f"cannot create the output folder {out}: {error.strerror}") from error
    if not os.access(out, os.W_OK | os.X_OK):
        raise ValueError(f"the output folder {out} is not writable")
    existing = [name for name in files if (out / name).exists()]
    if existing and not overwrite:
        raise ValueError(
            f"{out} already holds {', '.join(existing)}; pass --overwrite to replace them"
        )


def write_figure(spec: FigureSpec, out: Path, svg: bool = False) -> None:
    """Compute one figure and write its PNG, its CSVs and optionally its SVG into `out`."""
    data = spec.compute()
    if tuple(data) != spec.tables:
        raise RuntimeError(f"{spec.name} computed tables {tuple(data)}, expected {spec.tables}")
    for name in spec.tables:
        write_csv(out / spec.csv_name(name), data[name])
    figure = spec.draw(data)
    figure.savefig(out / f"{spec.name}.png", metadata={"Software": None})
    if svg:
        with matplotlib.rc_context({"svg.hashsalt": "tether-gym"}):
            figure.savefig(out / f"{spec.name}.svg", metadata={"Date": None, "Creator": None})


def build_parser() -> ArgumentParser:
    """The `tether-figures` command line."""
    parser = ArgumentParser(
        prog="tether-figures",
        description="Recompute the paper's figures (PNG + CSV) from the tether_gym physics.",
    )
    parser.add_argument("--out", type=Path, required=True, help="output folder")
    parser.add_argument("--overwrite", action="store_true", help="replace existing files")
    parser.add_argument("--svg", action="store_true", help="also write SVG files")
    parser.add_argument(
        "--only",
        nargs="+",
        choices=list(FIGURES),
        metavar="NAME",
        help=f"draw only these figures (of: {', '.join(FIGURES)})",
    )
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """The `tether-figures` command."""
    parser = build_parser()
    args = parser.parse_args(argv)
    specs = [FIGURES[name] for name in args.only or FIGURES]
    try:
        check_output(args.out, [f for spec in specs for f in spec.files(args.svg)], args.overwrite)
    except ValueError as error:
        parser.error(str(error))
    for spec in tqdm(specs, desc="figures", unit="figure"):
        write_figure(spec, args.out, args.svg)
    return 0


if __name__ == "__main__":
    sys.exit(main())
