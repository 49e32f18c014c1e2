"""Figures of the torsion models (matplotlib with the Agg backend, imported only here)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from monitor.report.plots import new_figure, save_figure
from monitor.torsion.shaft_line import CampbellData, ForcedResponse, Modes
from monitor.torsion.stability import StabilityChart
from monitor.torsion.time_response import TimeResponse

__all__ = [
    "plot_axial",
    "plot_campbell",
    "plot_modes",
    "plot_response",
    "plot_stability",
    "plot_time_response",
]


def plot_modes(modes: Modes, path: str | Path, *, count: int = 4, title: str = "") -> Path:
    """Mode shapes of the first ``count`` modes along the shaft line.

    Parameters
    ----------
    modes : Modes
    path : str or Path
        PNG file.
    count : int, optional
        Number of modes drawn.
    title : str, optional

    Returns
    -------
    Path
    """
    fig, ax, out = new_figure(path)
    x = np.arange(len(modes.node_names))
    for i in range(min(count, modes.frequencies.size)):
        shape = modes.shapes[:, i] / np.abs(modes.shapes[:, i]).max()
        ax.plot(x, shape, "o-", label=f"mode {i + 1}: {modes.frequencies_hz[i]:.2f} Hz")
    ax.axhline(0, color="k", lw=0.5)
    ax.set_xticks(x, modes.node_names, rotation=40, ha="right")
    ax.set(ylabel="relative twist [-]", title=title or "Torsional mode shapes")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return save_figure(fig, out)


def plot_campbell(
    data: CampbellData, path: str | Path, *, title: str = "", rated_rpm: float | None = None
) -> Path:
    """Campbell diagram: natural frequencies and excitation-order lines against crank speed.

    Parameters
    ----------
    data : CampbellData
    path : str or Path
        PNG file.
    title : str, optional
    rated_rpm : float, optional
        Marks the rated speed.

    Returns
    -------
    Path
    """
    fig, ax, out = new_figure(path)
    lo, hi = data.speed_range_rpm
    rpm = np.array([0.0, hi])
    top = max(float(data.orders.max()) * hi / 60, float(data.frequencies_hz[:3].max(initial=0.0)) * 1.2)
    for k in data.orders:
        ax.plot(rpm, k * rpm / 60, color="0.6", lw=0.8)
        ax.text(hi, k * hi / 60, f" {k:g}", fontsize=7, va="center")
    for i, f in enumerate(data.frequencies_hz):
        if f <= top:
            ax.axhline(f, color=f"C{i % 10}", lw=1.5, label=f"mode {i + 1}: {f:.2f} Hz")
    for _, order, speed in data.critical_speeds_rpm:
        ax.plot(speed, order * speed / 60, "ko", ms=4)
    if rated_rpm:
        ax.axvline(rated_rpm, color="r", ls="--", lw=1, label=f"rated {rated_rpm:g} rpm")
    ax.axvspan(0, lo, color="0.9")
    ax.set(
        xlim=(0, hi * 1.05),
        ylim=(0, top),
        xlabel="crank speed [rpm]",
        ylabel="frequency [Hz]",
        title=title or "Campbell diagram",
    )
    ax.legend(fontsize=8, loc="upper left")
    ax.grid(alpha=0.3)
    return save_figure(fig, out)


def plot_response(
    response: ForcedResponse, node: int, path: str | Path, *, title: str = "", top: int = 6
) -> Path:
    """Vibratory angle of one node per excitation order against crank speed.

    Parameters
    ----------
    response : ForcedResponse
    node : int
        Node index.
    path : str or Path
        PNG file.
    title : str, optional
    top : int, optional
        Number of strongest orders drawn.

    Returns
    -------
    Path
    """
    fig, ax, out = new_figure(path)
    rpm = response.speed * 30 / math.pi
    amplitude = np.abs(response.angle[node]) * 1e3
    strongest = np.argsort(amplitude.max(axis=0))[::-1][:top]
    for j in sorted(strongest):
        ax.plot(rpm, amplitude[:, j], label=f"order {response.orders[j]:g}")
    ax.plot(rpm, amplitude.sum(axis=1), "k--", lw=1, label="sum of orders")
    ax.set(
        xlabel="crank speed [rpm]",
        ylabel="vibratory angle [mrad]",
        title=title or f"Forced torsional response at {response.node_names[node]}",
    )
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return save_figure(fig, out)


def plot_stability(
    chart: StabilityChart, path: str | Path, *, marks: dict[str, list[tuple[float, float]]] | None = None
) -> Path:
    """Stability chart over (r, epsilon): growth rate where unstable.

    Parameters
    ----------
    chart : StabilityChart
    path : str or Path
        PNG file.
    marks : dict, optional
        Named lists of (r, epsilon) points drawn on top (e.g. published boundaries).

    Returns
    -------
    Path
    """
    fig, ax, out = new_figure(path)
    extent = (chart.r[0], chart.r[-1], chart.epsilon[0], chart.epsilon[-1])
    image = ax.imshow(
        np.where(chart.unstable, chart.growth_rate, np.nan),
        origin="lower",
        aspect="auto",
        extent=extent,
        cmap="magma_r",
    )
    fig.colorbar(image, ax=ax, label="growth rate per radian of crank angle [-]")
    ax.contour(chart.r, chart.epsilon, chart.unstable.astype(float), levels=[0.5], colors="k", linewidths=0.7)
    for i, (name, points) in enumerate((marks or {}).items()):
        if points:
            r, e = zip(*points, strict=True)
            ax.plot(r, e, "o", mfc="none", color=f"C{i}", label=name)
    if marks:
        ax.legend(fontsize=8)
    ax.set(
        xlabel="r = crank speed / natural frequency",
        ylabel="epsilon (reciprocating share of inertia)",
        title="Instability of the variable-inertia crank (shaded: unstable)",
    )
    return save_figure(fig, out)


def plot_time_response(response: TimeResponse, path: str | Path, *, title: str = "") -> Path:
    """gamma against revolutions.

    Parameters
    ----------
    response : TimeResponse
    path : str or Path
        PNG file.
    title : str, optional

    Returns
    -------
    Path
    """
    fig, ax, out = new_figure(path, size=(11, 4.5))
    ax.plot(response.tau / (2 * math.pi), response.gamma, lw=0.8)
    ax.set(xlabel="revolutions", ylabel="gamma [rad]", title=title or "Torsional response")
    ax.grid(alpha=0.3)
    return save_figure(fig, out)


def plot_axial(
    speed_rpm: np.ndarray, orders: np.ndarray, amplitude_um: np.ndarray, path: str | Path, *, title: str = ""
) -> Path:
    """Axial vibration per order against crank speed.

    Parameters
    ----------
    speed_rpm : ndarray, shape (n_speeds,)
        [rpm].
    orders : ndarray, shape (n_orders,)
        [-].
    amplitude_um : ndarray, shape (n_speeds, n_orders)
        Axial amplitude [um].
    path : str or Path
        PNG file.
    title : str, optional

    Returns
    -------
    Path
    """
    fig, ax, out = new_figure(path)
    strongest = np.argsort(amplitude_um.max(axis=0))[::-1][:6]
    for j in sorted(strongest):
        ax.plot(speed_rpm, amplitude_um[:, j], label=f"order {orders[j]:g}")
    ax.plot(speed_rpm, amplitude_um.sum(axis=1), "k--", lw=1, label="sum of orders")
    ax.set(xlabel="crank speed [rpm]", ylabel="axial amplitude [um]", title=title or "Axial vibration")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return save_figure(fig, out)
