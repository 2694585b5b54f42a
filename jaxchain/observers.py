"""Observers: quantities computed along the one solve.

peak = jc.observers.PeakRecord(samples=4)     # each accepted step's top force, 5 samples
soft = jc.observers.SoftPeak(t_start, rise, temperature, reference)   # integrated
sampled = jc.observers.SampledSoftPeak(t_start, rise, temperature, reference, samples=8)
# the same soft peak by the trapezoid rule on 8 parts of each step (fixed-step design)
# windows in revolutions of a reference sprocket (the driver by default)
lines = jc.observers.OrderSpectrum(range(64), 0.2, 2.2, signal="torque", sprocket=1, reference=0)
band = jc.observers.BandLevel.mesh_band(18, 0.2, 2.2)   # largest line, 0.5-3.5 mesh orders [dB]
chordal = jc.observers.SpeedVariation(0.2, 2.2, sprocket=1)
work = jc.observers.LoadWork()   # (S,) work the loads take out since the start [J]
meshing = jc.observers.EngagementPeaks(window=0.5)   # every meshing event's peak force
# (per sprocket and roller, windows in tooth periods); read with jc.engagement_peaks(sol)
sol = jc.simulate(scene, t1, observers=(lines, chordal)); sol.observed

A step observer sees every accepted step (start and end states, the solver's dense
interpolant); an integral observer adds an integrand that the solver integrates under its
error control. ``simulate`` carries a :class:`PeakRecord` (and any observers passed to
it); the design objectives a :class:`SoftPeak` or the observer they are given. New
objectives computed inside the solve subclass one of the two abstract classes.
"""

from ._numerics import parabola_max as parabola_max
from ._observers.base import (
    EXP_CAP as EXP_CAP,
    AbstractIntegralObserver as AbstractIntegralObserver,
    AbstractObserver as AbstractObserver,
    AbstractStepObserver as AbstractStepObserver,
    LoadWork as LoadWork,
    PeakRecord as PeakRecord,
    SampledSoftPeak as SampledSoftPeak,
    SoftPeak as SoftPeak,
    window_weight as window_weight,
)
from ._observers.engagements import (
    EngagementPeaks as EngagementPeaks,
    EngagementRecord as EngagementRecord,
)
from ._observers.orders import (
    SIGNALS as SIGNALS,
    BandLevel as BandLevel,
    OrderSpectrum as OrderSpectrum,
    SpeedVariation as SpeedVariation,
    hann_window as hann_window,
    level_db as level_db,
)

#: the public names (what the API reference and ``import *`` show)
__all__ = [
    "AbstractIntegralObserver",
    "AbstractObserver",
    "AbstractStepObserver",
    "BandLevel",
    "EXP_CAP",
    "EngagementPeaks",
    "EngagementRecord",
    "LoadWork",
    "OrderSpectrum",
    "PeakRecord",
    "SIGNALS",
    "SampledSoftPeak",
    "SoftPeak",
    "SpeedVariation",
    "hann_window",
    "level_db",
    "parabola_max",
    "window_weight",
]
