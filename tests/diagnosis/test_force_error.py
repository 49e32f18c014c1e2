"""The bearings' force errors that the strengths' covariance gives, by a route apart from their formula.

The combined bearing force is linear in the strengths, so cylinder ``c``'s sensitivity is the
difference of two combinations (strength 1 for ``c`` alone, and all motored) through
:func:`combine_cylinders`, which turns each cylinder's forces into the engine's frame. The error is
then ``sqrt(g^H C g)`` summed by hand. On a V the cylinders' axes lean, so a sensitivity left in each
cylinder's own axes mixes the wrong components; in-line engines are checked alongside.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from monitor.diagnosis.analysis import _force_error
from monitor.model.crankshaft import EngineModel
from monitor.model.engine import bundled_engines, load_engine
from monitor.model.predicted import combine_cylinders, cylinder_parts


@pytest.mark.parametrize("name", ["medium-speed-12v32", "high-speed-16v170", "medium-speed-6l32"])
def test_force_error_is_the_covariance_through_the_combined_bearing_forces(
    name: str, rng: np.random.Generator
) -> None:
    engine = load_engine(bundled_engines()[name])
    model = EngineModel(engine)
    parts = cylinder_parts(model, crank_speed=engine.rated_speed, load=0.8, max_order=8)
    n = engine.cylinders
    factor = rng.normal(size=(n, n)) * 0.05
    covariance = factor @ factor.T  # a full, positive definite covariance of the strengths [-]

    motored = combine_cylinders(parts, engine, np.zeros(n)).bearing_force
    g = np.stack([combine_cylinders(parts, engine, np.eye(n)[c]).bearing_force - motored for c in range(n)])
    expected = np.sqrt(np.einsum("cbko,cd,dbko->bko", g, covariance, np.conj(g)).real)

    got = _force_error(parts, engine, covariance)
    # both sum the same few products of terms of the bearing forces' scale: round-off of that scale
    scale = np.abs(g).max() * math.sqrt(np.abs(covariance).max()) * n
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12 * scale)
    assert expected.max() > 1e-3 * scale  # the errors compared are not round-off themselves
