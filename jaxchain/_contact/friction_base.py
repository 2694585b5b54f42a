"""The friction-law protocol: what a tangential contact law tells the elements that use it
(the clearance joints' contacts, the lumped chain's joint moments, roller/tooth and
roller/shoe contacts)."""

from __future__ import annotations

import abc

import equinox as eqx
from jaxtyping import Array, ArrayLike

__all__ = ["AbstractFrictionLaw", "contact_states", "flat_rate"]


class AbstractFrictionLaw(eqx.Module):
    """A tangential contact force law F_t(F_n, v_t, z), optionally with states z of its
    own per contact (a pre-sliding deflection, a bristle).

    A concrete law gives :meth:`traction`, declares ``states_per_contact:
    ClassVar[int] = k`` (a class variable, not a field) and, when k > 0,
    :meth:`state_rate`. An element that uses the law keeps ``states_per_contact`` states
    per contact in the drive state (``DriveState.bristle``), starting at zero, and
    integrates them with :meth:`state_rate`; a law without states gets ``None``.

    Sign convention: the force opposes the slip velocity v_t [m/s] that builds it up
    (F_t·v_t ≤ 0 in steady sliding).
    """

    #: how many states of its own the law keeps per contact (static; 0: none)
    states_per_contact: eqx.AbstractClassVar[int]

    @abc.abstractmethod
    def traction(
        self, normal_force: ArrayLike, slip_velocity: ArrayLike, state: ArrayLike | None
    ) -> Array:
        """Tangential force [N] of contacts with normal force ``normal_force`` [N] ≥ 0,
        slip velocity ``slip_velocity`` [m/s] and the law's states ``state`` (None for a
        law without states). Exactly linear in the normal force: an unloaded contact
        carries no friction."""

    def state_rate(self, state: ArrayLike | None, slip_velocity: ArrayLike) -> Array | None:
        """d/dt of the law's states at slip velocity ``slip_velocity`` [m/s] (None for a
        law without states)."""
        del state, slip_velocity
        return None


def contact_states(law: AbstractFrictionLaw, flat: Array | None, count: int) -> Array | None:
    """The per-contact states of ``count`` contacts under ``law`` from their flat slice of
    the drive state: (count,) for one state per contact, (count, k) for k; None for a law
    without states."""
    k = law.states_per_contact
    if k == 0 or flat is None:
        return None
    return flat if k == 1 else flat.reshape((count, k))


def flat_rate(rate: Array | None) -> Array | None:
    """A law's state rates, flattened back into the drive state's layout."""
    return None if rate is None else rate.reshape((-1,))
