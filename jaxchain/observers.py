"""Observers: quantities computed along the one solve.

peak = jc.observers.PeakRecord(samples=4)     # each accepted step's top force, 5 samples
soft = jc.observers.SoftPeak(t_start, rise, temperature, reference)   # integrated

A step observer sees every accepted step (start and end states, the solver's dense
interpolant); an integral observer adds an integrand that the solver integrates under its
error control. ``simulate`` carries a :class:`PeakRecord`; the design objectives a
:class:`SoftPeak`. New objectives computed inside the solve subclass one of the two
abstract classes.
"""

from ._numerics import parabola_max as parabola_max
from ._observers import (
    EXP_CAP as EXP_CAP,
    AbstractIntegralObserver as AbstractIntegralObserver,
    AbstractObserver as AbstractObserver,
    AbstractStepObserver as AbstractStepObserver,
    PeakRecord as PeakRecord,
    SoftPeak as SoftPeak,
    window_weight as window_weight,
)
