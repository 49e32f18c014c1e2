"""Scenes: simulate only the effects a scene calls for (see :mod:`monitor.scene.model`)."""

from monitor.scene.effects import EFFECTS
from monitor.scene.loading import load_scene, parse_scene
from monitor.scene.model import Scene
from monitor.scene.simulation import Simulation, simulate

__all__ = ["EFFECTS", "Scene", "Simulation", "load_scene", "parse_scene", "simulate"]
