"""The crank speed's low orders of a real engine at three loads, predicted from its own cylinder pressure.

The engine: the single-cylinder four-stroke spark-ignition rig of the TU/e
(4GB10; bore 67.7 mm, stroke 55 mm, rod 84.2 mm, compression ratio 8.5) on
E10 fuel at no, half and full load (``tue-4gb10`` in the shared external data;
its SOURCES.md), each run 0.5 s at 100 kHz with a 60-2 tooth wheel on the
crank and the cylinder pressure in volts of an unknown calibration.

The route, apart from the product's model:

1. TDC from the motored coast-down (ENGINEOFF4): the compression peaks with
   the product's tooth-wheel decoding and peak finder, 0.7 deg of loss angle;
   the wheel does not move between runs, so one angle serves all of them.
2. Each fired run through the product's measured side (``spectra``, one cycle
   per block): the crank speed's complex orders with their standard errors
   from the blocks, and the pressure's orders up to 48 (its synchronous
   average, in volts), synthesised on a grid of 0.5 deg.
3. The pressure's offset pegged by the compression polytrope: between 100 and
   40 deg before firing TDC (after inlet closing, before the spark) ``(v -
   v_0) V^n`` is constant with ``n = 1.30``, a least-squares line in ``V^n``
   whose intercept gives the zero-pressure voltage ``v_0`` (Randolph, SAE
   900170, 1990: pegging by the polytropic exponent; 1.30 within the 1.25 to
   1.35 of spark-ignition compression).  A throttled engine has no known
   manifold pressure at part load, so pegging at BDC to ambient would be wrong
   there; the polytrope needs no gain.
4. Gas torque ``T = p A dx/dtheta`` with the exact slider-crank lever
   ``dx/dtheta = R sin(theta) (1 + lambda cos(theta) / sqrt(1 - lambda^2
   sin^2(theta)))``, in volts times metres cubed until a gain is given.
5. A rigid crank at each run's mean speed: ``J omega_bar d omega / d theta =
   T - T_mean``, so the speed order ``W_k = T_k / (i k J omega_bar)``.

The half orders (0.5, 1.5, 2.5, 3.5) need nothing more: the inertia torque of
the reciprocating parts, the crankcase pressure and the pressure's offset
``v_0`` times the lever are periodic in one revolution and carry integer orders
only, and so do the tooth wheel's pitch errors.  Their ratios between loads
are free of the gain, the inertia, the offset and the masses.  The integer
orders are not compared: they also carry the inertia torque of the
reciprocating parts (mass unknown), the crankcase pressure against a pressure
of unknown gain, and the wheel's pitch errors, which the product's pitch-error
estimate cannot tell from the engine's own integer orders on a run this short.

A gain is needed only for an absolute inertia: at full load the throttle is
wide open, so the pressure at BDC of intake is taken as the ambient 1.013 bar
(an assumption, stated in the table).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from monitor.io.recording import Channel, Recording
from monitor.signal.measure import spectra
from monitor.signal.reference import angle_reference
from monitor.signal.tdc import pressure_peaks
from monitor.types import ComplexArray, FloatArray

__all__ = [
    "HALF_ORDERS",
    "RUNS",
    "OrderRatio",
    "RigRun",
    "common_scale",
    "first_tooth_angle",
    "order_ratios",
    "rig_run",
    "rig_runs",
    "wide_open_gain",
]

BORE = 0.0677
STROKE = 0.055
ROD = 0.0842
COMPRESSION_RATIO = 8.5
AMBIENT = 1.013e5
#: The runs by load, in the order of the table: file stems in the data folder.
RUNS = (
    ("no", "E10NOLOAD1"),
    ("half", "E10HALFLOAD1"),
    ("half", "E10HALFLOAD2"),
    ("full", "E10FULLLOAD1"),
    ("full", "E10FULLLOAD2"),
)
MOTORED = "ENGINEOFF4"
#: Orders free of the inertia torque, the pressure's offset and the wheel's pitch errors [-].
HALF_ORDERS = (0.5, 1.5, 2.5, 3.5)
POLYTROPIC = 1.30
PEG_WINDOW_DEG = (-100.0, -40.0)
GRID = 1440  # points over the 720 deg cycle
SAMPLE_RATE = 1e5


def _recording(folder: Path, stem: str, first_tooth_angle_deg: float) -> Recording:
    """A run's tooth wheel and pressure as a recording (columns time, wheel [V], pressure [V])."""
    _, tooth, pressure = np.loadtxt(folder / f"{stem}.txt").T
    fields: dict[str, float | int | str] = {
        "teeth": 60,
        "missing_teeth": 2,
        "first_tooth_angle_deg": first_tooth_angle_deg,
    }
    return Recording(
        "kluczyk-1cyl-4stroke",
        "2026-11-23T00:00:00Z",
        (
            Channel("tooth", "tooth", "V", tooth, SAMPLE_RATE, fields=fields),
            Channel("p1", "pressure", "V", pressure, SAMPLE_RATE, fields={"cylinder": 1}),
        ),
    )


def first_tooth_angle(folder: Path) -> float:
    """The wheel's first tooth after the gap, from TDC, by the motored coast-down's compression peaks.

    Parameters
    ----------
    folder : Path
        The ``tue-4gb10`` data folder.

    Returns
    -------
    float
        ``first_tooth_angle_deg`` [deg], in (-180, 180].
    """
    motored = _recording(folder, MOTORED, 0.0)
    reference = angle_reference(motored, cycle_revolutions=1)
    peaks = pressure_peaks(
        reference.angle_map,
        motored.channel("p1").data,
        SAMPLE_RATE,
        tdc_angle=0.0,
        period=2 * math.pi,
        window=math.radians(179.0),
        four_stroke=True,
    )
    return (math.degrees(peaks.tdc_offset()) + 180.0) % 360.0 - 180.0


def _kinematics(theta: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Piston displacement from TDC [m] and the exact lever dx/dtheta [m/rad]."""
    radius = STROKE / 2
    ratio = radius / ROD
    s, c = np.sin(theta), np.cos(theta)
    root = np.sqrt(1 - ratio**2 * s**2)
    return radius * (1 - c) + ROD * (1 - root), radius * s * (1 + ratio * c / root)


def _orders(samples: FloatArray) -> ComplexArray:
    """Complex orders (0, 0.5, 1, ...) of a cycle sampled from -360 deg, phase from firing TDC."""
    coefficients = np.fft.rfft(samples) / samples.size * 2
    coefficients[0] /= 2
    orders = np.arange(coefficients.size) / 2
    return np.asarray(coefficients * np.exp(-2j * math.pi * orders))


@dataclass(frozen=True)
class RigRun:
    """One run's measured crank-speed orders and the gas torque of its measured pressure.

    Attributes
    ----------
    name, load : str
        File stem and load ("no", "half", "full").
    mean_speed : float
        [rad/s].
    speed, speed_error : ndarray, shape (9,)
        Crank-speed orders 0 to 4 in steps of 0.5, complex [rad/s], and their standard errors from
        the cycle-to-cycle scatter [rad/s].
    torque_per_volt : ndarray, complex, shape (9,)
        Orders 0 to 4 of ``(v - v_0) A dx/dtheta``: the gas torque per unit gain [V m^3].
    offset : float
        Zero-pressure voltage ``v_0`` by the polytrope [V].
    bdc : float
        Pressure at BDC of intake above zero, ``v(-180 deg) - v_0`` [V].
    imep : float
        Net IMEP over the gain [V].
    """

    name: str
    load: str
    mean_speed: float
    speed: ComplexArray
    speed_error: FloatArray
    torque_per_volt: ComplexArray
    offset: float
    bdc: float
    imep: float

    def predicted_speed(self, scale: float) -> ComplexArray:
        """Speed orders 0.5 to 4 of a rigid crank, ``scale T_k / (i k omega_bar)``.

        Parameters
        ----------
        scale : float
            Gain over inertia, ``g / J`` [Pa/(V kg m^2)].

        Returns
        -------
        ndarray, complex, shape (8,)
            [rad/s].
        """
        k = np.arange(1, 9) / 2
        return np.asarray(scale * self.torque_per_volt[1:] / (1j * k * self.mean_speed))


def rig_run(folder: Path, stem: str, load: str, first_tooth_angle_deg: float) -> RigRun:
    """Measure one run and compute the gas torque of its pressure (see the module docstring).

    Parameters
    ----------
    folder : Path
        The ``tue-4gb10`` data folder.
    stem : str
        The run's file stem.
    load : str
        Its load, for the tables.
    first_tooth_angle_deg : float
        The wheel's angle from :func:`first_tooth_angle` [deg].

    Returns
    -------
    RigRun
    """
    recording = _recording(folder, stem, first_tooth_angle_deg)
    result = spectra(recording, cycle_revolutions=2, channels=["p1"], max_order=48, block_cycles=1)
    speed, pressure = result.spectra["crank speed"], result.spectra["p1"]
    theta = -2 * math.pi + 4 * math.pi * np.arange(GRID) / GRID
    volts = np.real(pressure.amplitude @ np.exp(1j * np.multiply.outer(pressure.orders, theta)))
    area = math.pi * BORE**2 / 4
    displacement, lever = _kinematics(theta)
    volume = area * (displacement + STROKE / (COMPRESSION_RATIO - 1))
    low, high = np.radians(PEG_WINDOW_DEG)
    window = (theta > low) & (theta < high)
    powered = volume[window] ** POLYTROPIC
    design = np.column_stack([np.ones(powered.size), powered])
    _, offset = np.linalg.lstsq(design, volts[window] * powered, rcond=None)[0]
    above = volts - offset
    bdc = float(np.interp(-math.pi, theta, above))
    imep = float(np.sum(above * area * lever) * (4 * math.pi / GRID) / (area * STROKE))
    return RigRun(
        name=stem,
        load=load,
        mean_speed=float(result.mean_speed),
        speed=np.asarray(speed.amplitude[:9]),
        speed_error=np.asarray(speed.standard_error[:9]),
        torque_per_volt=_orders(above * area * lever)[:9],
        offset=float(offset),
        bdc=bdc,
        imep=imep,
    )


def rig_runs(folder: Path) -> list[RigRun]:
    """Every run of :data:`RUNS`, with TDC from the motored coast-down.

    Parameters
    ----------
    folder : Path
        The ``tue-4gb10`` data folder.

    Returns
    -------
    list of RigRun
    """
    angle = first_tooth_angle(folder)
    return [rig_run(folder, stem, load, angle) for load, stem in RUNS]


@dataclass(frozen=True)
class OrderRatio:
    """A run's speed order over the full-load runs' mean, predicted and measured.

    Attributes
    ----------
    name : str
        The run.
    order : float
        [-].
    predicted, measured : float
        ``|W_k(run)| / mean |W_k(full)|`` from the pressure (gain and inertia cancel) and from the
        crank speed [-].
    error : float
        Standard error of the measured ratio from the blocks' scatter of both [-].
    """

    name: str
    order: float
    predicted: float
    measured: float
    error: float


def order_ratios(runs: list[RigRun], orders: tuple[float, ...] = HALF_ORDERS) -> list[OrderRatio]:
    """Each run's order ratios to full load, predicted from pressure and measured.

    Parameters
    ----------
    runs : list of RigRun
        With at least one full-load run.
    orders : tuple of float, optional
        Orders to compare [-].

    Returns
    -------
    list of OrderRatio
        Run by run, order by order.
    """
    full = [r for r in runs if r.load == "full"]
    ratios = []
    for order in orders:
        j = round(2 * order)
        reference_predicted = np.mean([abs(r.torque_per_volt[j]) / r.mean_speed for r in full])
        reference_measured = float(np.mean([abs(r.speed[j]) for r in full]))
        reference_error = math.sqrt(sum(r.speed_error[j] ** 2 for r in full)) / len(full)
        for run in runs:
            measured = abs(run.speed[j]) / reference_measured
            relative = math.hypot(
                run.speed_error[j] / abs(run.speed[j]), reference_error / reference_measured
            )
            ratios.append(
                OrderRatio(
                    name=run.name,
                    order=order,
                    predicted=float(abs(run.torque_per_volt[j]) / run.mean_speed / reference_predicted),
                    measured=float(measured),
                    error=float(measured * relative),
                )
            )
    return ratios


def common_scale(runs: list[RigRun], orders: tuple[float, ...] = HALF_ORDERS) -> tuple[float, float]:
    """One gain-over-inertia common to every run, fitted to the magnitudes of the speed's orders.

    Parameters
    ----------
    runs : list of RigRun
    orders : tuple of float, optional
        Orders fitted [-].

    Returns
    -------
    scale : float
        ``g / J`` [Pa/(V kg m^2)], by least squares on ``|W_k|`` weighted by the standard
        errors (magnitudes: the phases carry the TDC's own uncertainty of about a degree).
    reduced_chi_square : float
        The residual's sum of squares over the degrees of freedom, in standard errors [-].
    """
    model, data = [], []
    for run in runs:
        for order in orders:
            j = round(2 * order)
            model.append(abs(run.torque_per_volt[j]) / (order * run.mean_speed) / run.speed_error[j])
            data.append(abs(run.speed[j]) / run.speed_error[j])
    a, b = np.asarray(model), np.asarray(data)
    scale = float(a @ b / (a @ a))
    residual = b - scale * a
    return scale, float(residual @ residual / (b.size - 1))


def wide_open_gain(runs: list[RigRun]) -> float:
    """The pressure sensor's gain if the full-load runs' pressure at BDC of intake is ambient.

    Parameters
    ----------
    runs : list of RigRun
        With at least one full-load run.

    Returns
    -------
    float
        [Pa/V]: 1.013 bar over the mean of the full-load runs' ``bdc`` (wide-open throttle).
    """
    return AMBIENT / float(np.mean([r.bdc for r in runs if r.load == "full"]))
