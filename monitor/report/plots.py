"""Figures of model results (matplotlib, imported only here, with the Agg backend).

Plots are for people: a figure says at a glance which orders the engine's
physics puts where. Each function writes one PNG and returns its path.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from monitor.errors import MonitorError, PlotError
from monitor.io.files import in_existing_folder
from monitor.model.crankshaft import EngineModel
from monitor.model.engine import bundled_engines, load_engine
from monitor.model.predicted import ModelOrders

__all__ = [
    "check_figure_path",
    "diagnosis_title",
    "plot_diagnosis",
    "plot_model_orders",
    "plot_spectra",
    "plot_speed_maps",
]


def new_figure(
    path: str | Path,
    *,
    rows: int = 1,
    cols: int = 1,
    size: tuple[float, float] = (10, 5.5),
    squeeze: bool = True,
) -> tuple[Any, Any, Path]:
    """A figure for a PNG file (headless backend), in a folder that exists.

    Returns ``(figure, axes, path)``; ``axes`` is as ``matplotlib.pyplot.subplots``
    gives it (a single Axes for one panel unless ``squeeze=False``).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = in_existing_folder(path)
    fig, axes = plt.subplots(rows, cols, figsize=size, constrained_layout=True, squeeze=squeeze)
    return fig, axes, out


def check_figure_path(path: str | Path, *, formats: tuple[str, ...] | None = None) -> Path:
    """A figure's path, checked before any work: a format matplotlib writes, in a folder that exists.

    Parameters
    ----------
    path : str or Path
        The file asked for.
    formats : tuple of str, optional
        The suffixes the command writes (``compare``: png and html); default every format
        matplotlib writes.

    Returns
    -------
    Path

    Raises
    ------
    PlotError
        For a suffix no writer takes, or a folder that does not exist (it is not created).
    """
    out = Path(path)
    suffix = out.suffix.lower().lstrip(".")
    if formats is None:
        import matplotlib

        matplotlib.use("Agg")
        from matplotlib.figure import Figure

        formats = tuple(Figure().canvas.get_supported_filetypes())
    known = sorted(formats)
    if suffix not in known:
        raise PlotError(
            f"{path}: a figure cannot be written as {suffix or 'a file without a suffix'!r}: expected one of "
            + ", ".join(f".{k}" for k in known)
        )
    folder = out.parent if str(out.parent) else Path(".")
    if not folder.is_dir():
        raise PlotError(f"{path}: the folder {folder} does not exist (create it first)")
    return out


def save_figure(fig: Any, out: Path, *, dpi: int = 110, metadata: dict[str, str] | None = None) -> Path:
    """Write the figure to ``out`` and release it (``metadata``: the file's, e.g. a PNG's "Title")."""
    import matplotlib.pyplot as plt

    fig.savefig(out, dpi=dpi, metadata=metadata)
    plt.close(fig)
    return out


def plot_model_orders(result: ModelOrders, model: EngineModel, path: str | Path) -> Path:
    """Four panels: one cylinder's torque over the cycle, engine torque orders,
    inertia-force orders of one cylinder (log scale), and main-bearing force orders.

    Parameters
    ----------
    result : ModelOrders
        The predicted orders.
    model : EngineModel
        The model they came from (for the torque waveform).
    path : str or Path
        Output PNG file; its folder is created if needed.

    Returns
    -------
    Path
    """
    engine = model.engine
    orders = result.orders[1:]
    width = 0.35 / engine.cycle_revolutions

    fig, axes, out = new_figure(path, rows=2, cols=2, size=(13, 8.5))
    fig.suptitle(
        f"{engine.name}\n{result.speed_rpm:.1f} rpm, load {result.load:.2f}: predicted orders "
        f"({result.kinematics} kinematics, {result.rod_model} rod)"
    )

    ax = axes[0, 0]
    forces = model.cylinder_forces(result.crank_speed, result.load)
    degrees = np.degrees(model.crank_angle)
    kin = model.kinematics
    gas_torque = (
        forces.gas_force * engine.crank_radius * np.sin(kin.crank_angle + kin.beta) / np.cos(kin.beta)
    )
    ax.plot(degrees, forces.torque / 1e3, label="cylinder 1, total")
    ax.plot(degrees, gas_torque / 1e3, "--", label="cylinder 1, gas")
    ax.plot(degrees, (forces.torque - gas_torque) / 1e3, ":", label="cylinder 1, inertia and weight")
    ax.set(xlabel="crank angle from firing TDC [deg]", ylabel="torque [kN m]", title="Torque of one cylinder")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)

    ax = axes[0, 1]
    ax.bar(orders, np.abs(result.engine_torque[1:]) / 1e3, width=2 * width, color="tab:blue")
    ax.set(xlabel="order", ylabel="amplitude [kN m]", title="Engine torque orders (all cylinders)")
    ax.grid(alpha=0.3, axis="y")

    ax = axes[1, 0]
    floor = 1e-9
    for axis, label, shift in ((1, "vertical", -width / 2), (0, "horizontal", width / 2)):
        amp = np.maximum(np.abs(result.cylinder_inertia_force[0, axis, 1:]), floor)
        ax.bar(orders + shift, amp / 1e3, width=width, label=label)
    ax.set_yscale("log")
    ax.set_ylim(bottom=max(floor, 1e-6 * np.abs(result.cylinder_inertia_force[0]).max()) / 1e3)
    ax.set(xlabel="order", ylabel="amplitude [kN]", title="Inertia force of one cylinder's moving parts")
    ax.grid(alpha=0.3, axis="y", which="both")
    ax.legend(fontsize=8)

    ax = axes[1, 1]
    amp = np.abs(result.bearing_force[:, 1, 1:]) / 1e3
    image = ax.imshow(
        amp,
        aspect="auto",
        origin="lower",
        cmap="viridis",
        extent=(orders[0] - width, orders[-1] + width, 0.5, engine.bearing_count + 0.5),
    )
    fig.colorbar(image, ax=ax, label="vertical force amplitude [kN]")
    ax.set(xlabel="order", ylabel="main bearing", title="Main-bearing force orders (vertical)")
    ax.set_yticks(range(1, engine.bearing_count + 1))

    return save_figure(fig, out)


def plot_spectra(result: Any, path: str | Path, *, title: str = "") -> Path:
    """Order spectra of a recording: one panel per channel, amplitude on a log scale.

    Each bar is an order's amplitude, its whisker the blocks' spread; a red tick marks the bound a
    wheel's unlearned pitch errors put on a whole order of the crank speed (``systematic``).

    Parameters
    ----------
    result : monitor.signal.measure.SpectrumResult
    path : str or Path
        Output PNG.
    title : str, optional

    Returns
    -------
    Path
    """
    names = list(result.spectra)
    fig, axes, out = new_figure(path, rows=len(names), size=(11, 2.6 * len(names) + 0.8), squeeze=False)
    marked = False
    for ax, name in zip(axes[:, 0], names, strict=True):
        spectrum = result.spectra[name]
        orders, amplitude = spectrum.orders[1:], spectrum.magnitude[1:]
        ax.bar(orders, np.maximum(amplitude, 1e-12), width=0.35 / result.cycle_revolutions)
        ax.errorbar(
            orders,
            spectrum.magnitude_mean[1:],
            yerr=spectrum.magnitude_std[1:],
            fmt="none",
            ecolor="k",
            elinewidth=0.6,
            capsize=1.5,
        )
        systematic = spectrum.systematic[1:] if spectrum.systematic is not None else None
        if systematic is not None and np.any(systematic > 0):
            # the wheel's unlearned pitch errors: what an order may owe them, whatever the averaging
            bounded = systematic > 0
            ax.scatter(orders[bounded], systematic[bounded], marker="_", s=120, color="tab:red")
            marked = True
        ax.set_yscale("log")
        top = float(amplitude.max(initial=1e-12))
        ax.set_ylim(max(top * 1e-6, 1e-12), top * 3)
        ax.set(ylabel=f"[{result.units[name]}]", title=name)
        ax.grid(alpha=0.3, axis="y", which="both")
    axes[-1, 0].set_xlabel("order")
    fig.suptitle(title or "Order spectra")
    if marked:  # below the axes, in the space the constrained layout keeps for it
        fig.supxlabel(
            "whiskers: the blocks' spread; red ticks: the most the wheel's unlearned tooth-pitch errors can "
            "put in a whole order (systematic, not reduced by averaging)",
            fontsize="small",
        )
    return save_figure(fig, out, dpi=100)


def plot_speed_maps(result: Any, path: str | Path) -> Path:
    """Order amplitude against crank speed, one heat map per channel (log colour scale).

    Parameters
    ----------
    result : monitor.signal.measure.SpectrumResult
        With ``speed_maps``.
    path : str or Path
        Output PNG.

    Returns
    -------
    Path
    """
    names = list(result.speed_maps)
    fig, axes, out = new_figure(path, rows=len(names), size=(10, 3.2 * len(names) + 0.6), squeeze=False)
    from matplotlib.colors import LogNorm

    for ax, name in zip(axes[:, 0], names, strict=True):
        speed_map = result.speed_maps[name]
        rpm = speed_map.speed * 30 / np.pi
        values = np.where(speed_map.amplitude > 0, speed_map.amplitude, np.nan)[:, 1:]
        finite = values[np.isfinite(values)]
        top = float(finite.max()) if finite.size else 1.0
        image = ax.pcolormesh(
            speed_map.orders[1:],
            rpm,
            values,
            shading="nearest",
            norm=LogNorm(vmin=top * 1e-4, vmax=top),
            cmap="viridis",
        )
        fig.colorbar(image, ax=ax, label=f"amplitude [{result.units[name]}]")
        ax.set(xlabel="order", ylabel="crank speed [rpm]", title=name)
    return save_figure(fig, out, dpi=100)


STATUS_COLOURS = {"healthy": "tab:green", "warning": "tab:orange", "alarm": "tab:red", "inconclusive": "0.35"}


def diagnosis_title(status: str, summaries: Sequence[str], *, heading: str = "", width: int = 110) -> str:
    """A diagnosis figure's title: the status word first, then the findings, then the heading.

    The first line is the status in capitals followed by the findings' summaries, separated by
    semicolons, as many whole as fit in ``width`` characters; a first summary too long on its own is
    cut with an ellipsis; those left out are counted as "+N more". The heading (the recording, its
    engine and speed) is the second line. A figure seen alone so says what was found.

    Parameters
    ----------
    status : str
        "healthy", "warning", "alarm" or "inconclusive".
    summaries : sequence of str
        The findings' one-line summaries, in the diagnosis' order.
    heading : str, optional
        The second line.
    width : int, optional
        Characters the first line may take.

    Returns
    -------
    str
    """
    line = status.upper()
    for shown, summary in enumerate(summaries):
        left = len(summaries) - shown - 1
        more = f"; +{left} more" if left else ""
        candidate = f"{line}{':' if shown == 0 else ';'} {summary}"
        if len(candidate) + len(more) <= width:
            line = candidate
            continue
        if shown == 0:  # the first finding is shown even when it does not fit whole
            room = width - len(line) - 2 - len(more) - 1
            if room >= 20:
                line = f"{line}: {summary[:room].rstrip()}\u2026"
                continue
        line += f"{':' if shown == 0 else ';'} +{len(summaries) - shown} more"
        break
    return f"{line}\n{heading}" if heading else line


def plot_diagnosis(
    diagnosis: Any, path: str | Path, *, title: str = "", table: str = "", recording: str = ""
) -> Path:
    """Measured against predicted order spectra per channel, and the cylinder balance on a polar chart.

    Each channel's panel overlays the measured orders (bars) and the model's
    (markers), amplitudes on a log scale with the measured orders' standard
    error; the polar chart puts each cylinder at its firing angle with its
    strength relative to those that fire alike as the radius (the unit
    circle is "as the others"), with its 95 % interval. The figure's title
    carries the status and the findings (:func:`diagnosis_title`), in the
    status' colour, so a figure seen alone says what was found.

    Parameters
    ----------
    diagnosis : monitor.diagnosis.Diagnosis
    path : str or Path
        ``.png``, or ``.html`` for the recording view of the web pages (:mod:`monitor.report.web`) as one
        self-contained file: the status and findings on top, then charts that zoom and show values on
        hover, every script inline (a ship without network opens it).
    title : str, optional
        The title's second line, under the status and findings (default: the engine's id).
    table : str, optional
        Not used (the HTML page shows the findings and values itself); kept for callers.
    recording : str, optional
        The recording's name on an HTML page.

    Returns
    -------
    Path
    """
    out = Path(path)
    if out.suffix.lower() not in (".png", ".html", ".htm"):
        raise MonitorError(f"--plot {out}: expected a .png or .html file")
    if out.suffix.lower() != ".png":
        # the HTML page's documents need the diagnosis package (scipy): not for `orders --plot`
        from monitor.report.diagnosis import diagnosis_document
        from monitor.report.spectrum_json import spectrum_document
        from monitor.report.web import recording_page

        page = recording_page(
            diagnosis_document(diagnosis, recording=recording),
            spectrum_document(diagnosis.spectra, recording=recording, engine_id=diagnosis.engine_id),
        )
        out.write_text(page, encoding="utf-8")
        return out
    comparisons = [c for c in diagnosis.comparisons if c.orders.size]
    balance = diagnosis.balance
    rows = max(len(comparisons), 1)
    fig, axes, _ = new_figure(out, rows=rows, cols=2, size=(13, 2.8 * rows + 1.0), squeeze=False)
    gs = axes[0, 1].get_gridspec()
    for ax in axes[:, 1]:
        ax.remove()
    polar = fig.add_subplot(gs[:, 1], projection="polar")
    for ax, comparison in zip(axes[:, 0], comparisons, strict=False):
        k = comparison.orders
        measured, predicted = np.abs(comparison.measured), np.abs(comparison.predicted)
        width = 0.35 * (k[1] - k[0] if k.size > 1 else 1.0)
        ax.bar(k, np.maximum(measured, 1e-15), width=width, label="measured", color="tab:blue", alpha=0.75)
        ax.errorbar(k, measured, yerr=comparison.standard_error, fmt="none", ecolor="k", elinewidth=0.6)
        ax.plot(k, np.maximum(predicted, 1e-15), "o", ms=4, color="tab:red", label="predicted")
        top = float(max(measured.max(initial=0), predicted.max(initial=0), 1e-15))
        ax.set_yscale("log")
        ax.set_ylim(top * 1e-5, top * 3)
        ax.set(ylabel=f"[{comparison.unit}]", title=comparison.channel)
        ax.grid(alpha=0.3, axis="y", which="both")
        ax.legend(loc="upper right", fontsize=8)
    axes[-1, 0].set_xlabel("order")
    if balance is not None:
        angles = None
        if diagnosis.engine_id in bundled_engines():
            angles = load_engine(bundled_engines()[diagnosis.engine_id]).firing_angles
        n = balance.relative.size
        if angles is None or len(angles) != n:
            angles = np.arange(n) * (2 * math.pi / n)
        # the cycle around the circle: a four-stroke's 720 deg of firing angles at half their angle
        theta = np.mod(np.asarray(angles) / diagnosis.spectra.cycle_revolutions, 2 * math.pi)
        circle = np.linspace(0, 2 * math.pi, 200)
        polar.plot(circle, np.ones_like(circle), color="0.5", lw=0.8, ls="--")
        colours = ["tab:red" if r < 0.85 else "tab:green" for r in balance.relative]
        polar.bar(theta, np.clip(balance.relative, 0, None), width=0.25, color=colours, alpha=0.7)
        polar.errorbar(
            theta,
            np.clip(balance.relative, 0, None),
            yerr=1.96 * balance.relative_error,
            fmt="none",
            ecolor="k",
        )
        for c in range(n):
            polar.annotate(
                balance.name(c), (theta[c], max(balance.relative[c], 0) + 0.12), ha="center", fontsize=9
            )
        polar.set_ylim(0, max(1.3, float(np.max(balance.relative)) + 0.2))
        polar.set_theta_zero_location("N")
        polar.set_theta_direction(-1)
        against = "its bank's cylinders" if any(balance.banks) else "the cylinders"
        polar.set_title(
            f"cylinder strength against {against} that fire alike\n(at its firing angle in the cycle)"
        )
    else:
        polar.set_title("no cylinder balance")
    size = 13.0  # points
    heading = diagnosis_title(
        diagnosis.status,
        [f.summary for f in diagnosis.findings],
        heading=title or diagnosis.engine_id,
        width=int(fig.get_figwidth() * 72 / (0.55 * size)),  # characters of about 0.55 em
    )
    fig.suptitle(heading, fontsize=size, color=STATUS_COLOURS.get(diagnosis.status, "black"))
    return save_figure(fig, out, dpi=100, metadata={"Title": heading})  # the title in its metadata too
