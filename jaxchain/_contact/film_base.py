"""The joint-film protocol: what a lubricant film in a revolute clearance joint (pin in
bush, bush in roller) tells the joint that carries it."""

from __future__ import annotations

import abc

import equinox as eqx
from jaxtyping import Array, ArrayLike

__all__ = ["AbstractFilmLaw"]


class AbstractFilmLaw(eqx.Module):
    """A fluid film between a journal and its bearing: the force of the film's pressure
    and the torque of its shear, from the journal's offset and motion in the bearing.

    The joint that carries it (:class:`~jaxchain.elements.ClearanceJoints` with
    ``film=``) adds the film beside its dry contact law, which still acts where the film
    breaks down (mixed lubrication), and balances the film's moments so that the pair
    conserves angular momentum: the pressure force F acts through the journal's centre on
    the journal and −F through the bearing's centre on the bearing; the shear torque on
    the journal is ``friction_torque`` − (e × F)/2 and on the bearing −``friction_torque``
    − (e × F)/2 (the bearing's and the journal's shear torques differ by e × F, the
    classical journal-bearing result). The power of the film on the pair is then
    F·w + T·Ω with w the effective squeeze velocity: a film law that only dissipates
    keeps both terms ≤ 0.

    Every quantity is in the bearing's frame: the law must be isotropic (rotating the
    eccentricity and its rate rotates the force), so any axes that turn with the bearing
    serve.
    """

    @abc.abstractmethod
    def force(
        self,
        eccentricity: ArrayLike,
        eccentricity_rate: ArrayLike,
        spin: ArrayLike,
        clearance: ArrayLike,
        radius: ArrayLike,
        length: ArrayLike,
    ) -> Array:
        """(2,) film force on the journal [N] from its centre's offset ``eccentricity``
        (2,) [m] from the bearing's centre, the offset's rate ``eccentricity_rate`` (2,)
        [m/s] seen from the bearing, the journal's spin relative to the bearing ``spin``
        [rad/s], the radial clearance [m], the journal's radius [m] and the film's
        length [m]. Finite with finite gradients for any offset, including beyond the
        clearance (where the dry contact takes the load)."""

    @abc.abstractmethod
    def friction_torque(
        self,
        eccentricity: ArrayLike,
        spin: ArrayLike,
        clearance: ArrayLike,
        radius: ArrayLike,
        length: ArrayLike,
    ) -> Array:
        """The film's shear torque on the journal [N·m], opposing ``spin``."""

    @abc.abstractmethod
    def damping(
        self, eccentricity_ratio: ArrayLike, clearance: ArrayLike, radius: ArrayLike,
        length: ArrayLike,
    ) -> Array:  # fmt: skip
        """The film's damping of the journal's radial approach [N·s/m] at an eccentricity
        ratio: what sets the film's part of an explicit solver's stable step."""
