"""Loads on a driven sprocket's shaft: ``load_torque=`` of every builder takes a number or
one of these.

cam = jc.loads.Harmonic(2.0, harmonics=((4, 6.0, 0.0), (8, 2.0, 0.5)))  # N·m, per cam turn
cam = jc.loads.camshaft_torque(engine_rpm=3000)  # a four-cylinder 16-valve valve train
drive = jc.scenes.drive("06B", teeth=(21, 42, 42), centres=..., load_torque=cam)

``torque(t, angle, speed)`` [N·m] resists the sprocket's rotation; ``angle`` is the angle
it has turned since the start and ``speed`` its speed, both in its running direction. A
new load subclasses :class:`AbstractLoad`.
"""

from ._loads import (
    AbstractLoad as AbstractLoad,
    Constant as Constant,
    Harmonic as Harmonic,
    Ramped as Ramped,
    camshaft_torque as camshaft_torque,
)

#: the public names (what the API reference and ``import *`` show)
__all__ = [
    "AbstractLoad",
    "Constant",
    "Harmonic",
    "Ramped",
    "camshaft_torque",
]
