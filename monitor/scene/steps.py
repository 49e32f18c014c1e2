"""Load steps: a scene whose load changes inside the recording, simulated epoch by epoch.

An epoch is the span between two steps (the first from the start at the operating point's load).
Each epoch's sources are those of the scene at its load (:func:`monitor.scene.sources.sources_of`):
the cylinders' heat release and charge pressure follow the load as the engine's cycle states, and
with them the torque, the bearing forces and the cylinder pressures. The recording is joined at the
steps: every waveform sample takes the value of the epoch its time lies in, the rigid crank's speed
fluctuation the epoch of the time its angle is reached.

The mean speed keeps the scene's trend through a step, as a generator's governor holds it: the
simulator is quasi-static (the torque's orders at each mean speed, no equation of the mean speed's
motion), so a step changes the speed's fluctuation and not its mean. The join is instantaneous; a
real engine's combustion follows its fuel rack over a cycle or two, which a diagnosis per steady
segment leaves out with the transition anyway. Only the rigid crank (or none) is joined: the shaft
line's and the variable-inertia crank's responses are tabulated for one set of sources, and a scene
with steps and either of them is refused.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from monitor.errors import SceneError
from monitor.scene.effects import CrankSpeedParams, named
from monitor.scene.model import Scene
from monitor.types import FloatArray

__all__ = ["check_steps", "epoch_scenes", "joined"]


def check_steps(scene: Scene, *, origin: str = "scene") -> None:
    """Refuse load steps the simulation cannot give (nothing to step, or a crank model it cannot join).

    Parameters
    ----------
    scene : Scene
    origin : str, optional
        Where the scene came from, for messages.

    Raises
    ------
    SceneError
        For load steps without the ``gas`` effect (nothing depends on the load), or with the
        shaft-line or variable-inertia crank.
    """
    if not scene.operating_point.load_steps:
        return
    if "gas" not in scene.effects:
        raise SceneError(
            f"{origin}: operating_point.load_steps change the gas pressure: add the effect 'gas'"
        )
    crank = named(scene, "crank_speed")
    if isinstance(crank, CrankSpeedParams) and crank.model != "rigid":
        raise SceneError(
            f"{origin}: operating_point.load_steps are joined on the rigid crank only; crank_speed model "
            f"{crank.model!r} tabulates one load: use model = 'rigid' or remove the steps"
        )


def epoch_scenes(scene: Scene) -> list[tuple[float, Scene]]:
    """Each epoch's start [s] and the scene at its load, without steps (the first: the scene's load).

    Parameters
    ----------
    scene : Scene

    Returns
    -------
    list of (float, Scene)
        One per epoch, in time order; a scene without steps gives itself alone.
    """
    op = scene.operating_point
    return [
        (
            start,
            scene.model_copy(
                update={"operating_point": op.model_copy(update={"load": load, "load_steps": []})}
            ),
        )
        for start, load in op.loads()
    ]


def joined(starts: Sequence[float], values: Sequence[FloatArray], times: FloatArray) -> FloatArray:
    """Each epoch's values where ``times`` lie in it: the epoch-by-epoch join at the steps.

    Parameters
    ----------
    starts : sequence of float
        The epochs' starts, increasing, the first 0 [s].
    values : sequence of ndarray
        Each epoch's values at ``times``, all of one shape [any unit].
    times : ndarray
        The time of each value [s].

    Returns
    -------
    ndarray
        Of the shape of each ``values[i]``.
    """
    epoch = np.searchsorted(np.asarray(starts), times, side="right") - 1
    out = np.array(values[0], copy=True)
    for i in range(1, len(values)):
        out = np.where(epoch == i, values[i], out)
    return np.asarray(out)
