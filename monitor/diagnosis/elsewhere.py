"""A knock heard elsewhere: each impact span's score on the engine's other bearing sensors.

A knock is heard loudest on the sensor of the bearing that knocks; the engine's own noise, moved by a
misfire or a load change, is heard alike on all.  The decision rule
(:func:`monitor.diagnosis.findings.bearing_findings`, :data:`~monitor.diagnosis.findings.LOCALISED`)
weighs a span's excess on its own sensor against the highest excess of the same span on the others.
"""

from __future__ import annotations

import math
from dataclasses import replace

from monitor.diagnosis.baseline import Baseline
from monitor.diagnosis.bearings import span_score
from monitor.diagnosis.findings import BearingResult
from monitor.diagnosis.impact_reference import reference_profile
from monitor.model.engine import Engine
from monitor.signal.impact import HighFrequencyPower

__all__ = ["with_elsewhere"]


def with_elsewhere(
    bearings: list[BearingResult],
    profiles: dict[str, HighFrequencyPower],
    engine: Engine,
    baseline: Baseline | None,
    level: float = math.nan,
) -> list[BearingResult]:
    """Each impact score with the same knock span's score on the other bearing sensors (the highest).

    Parameters
    ----------
    bearings : list of BearingResult
    profiles : dict of str to HighFrequencyPower
        Each bearing sensor's profile in the recording.
    engine : Engine
    baseline : Baseline or None
    level : float, optional
        The engine's high-frequency level over the baseline's [-]
        (:func:`monitor.diagnosis.impact_reference.engine_level`; NaN: each sensor's own).

    Returns
    -------
    list of BearingResult
        With :attr:`ImpactScore.elsewhere` and :attr:`BearingResult.elsewhere` set.
    """
    R = engine.cycle_revolutions
    out = []
    for result in bearings:
        scored = []
        for score in result.impacts:
            heard = []
            for other in bearings:
                profile = profiles.get(other.channel)
                if other.channel == result.channel or profile is None:
                    continue
                known = baseline.sensors.get(other.channel) if baseline is not None else None
                theirs = known.high_frequency if known is not None else None
                matched = reference_profile(theirs, profile, R, level)
                heard.append(span_score(matched.profile, score.angle_deg, R, matched.reference))
            scored.append(replace(score, elsewhere=max(heard) if heard else math.nan))
        own = next((s for s in scored if s.bearing == result.bearing), None)
        out.append(replace(result, impacts=scored, elsewhere=own.elsewhere if own is not None else math.nan))
    return out
