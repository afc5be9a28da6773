"""One registry of the bounce models: what each needs, and the functions that run it.

`MODELS` maps a model's name to its `Model`; `name in MODELS` and iteration over the names work
as with a tuple of names. `api.bounce` and `api.bounce_one` (the launch frame) and the world
contacts all dispatch through it, so that a model is added in one place. A model's code in the
compiled env kernels is its index in `MODELS` (`DYNAMICS`; `IMPULSE`, `HYBRID`, `PYMUNK`).
pymunk, a heavy optional engine, is imported on first use only.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import NamedTuple

from tether_gym.physics.contact import hybrid_contact, impulse_contact, pymunk_contact
from tether_gym.physics.hybrid import hybrid_bounce, hybrid_kernel
from tether_gym.physics.impulse import impulse_bounce, impulse_kernel


class LaunchArgs(NamedTuple):
    """The arguments of every model's launch-frame bounce, in their order (`Model.bounce_one`
    takes them as floats, `Model.bounce_kernel` as flat arrays); a model ignores those it has no
    use for."""

    tether_angle: float
    """The paper's beta, rad."""
    offset_angle: float
    """The paper's alpha at tautening, rad."""
    offset: float
    """The attachment point's distance from the centre of mass over the radius."""
    inertia_ratio: float
    """kappa = I / (m R^2)."""
    speed: float
    """m/s, before the bounce, along +y."""
    spin: float
    """rad/s, before the bounce."""
    restitution: float
    radius: float
    """m."""
    mass: float
    """kg."""
    tether_length: float
    """The rest length L0, m."""
    stiffness: float
    """N/m (a stand-in for the impulse model)."""


@dataclass(frozen=True)
class Model:
    """A bounce model and the functions that run it."""

    name: str
    needs_stiffness: bool
    """A spring tether: the stiffness is required and the restitution must be in (0, 1]."""
    bounce_one: Callable = field(repr=False)
    """The launch-frame bounce from plain floats (`LaunchArgs`, in order) -> (vx, vy, spin,
    bounced, completed, contact_time)."""
    bounce_kernel: Callable = field(repr=False)
    """The launch-frame bounce of a batch: the same arguments as flat float64 arrays of
    length n or 1, then the outputs it fills: velocity (n, 2), spin, deflection, speed ratio,
    bounced, completed, contact time."""
    contact: Callable = field(repr=False)
    """The world-frame contact of a batch (`contact.impulse_contact`'s arguments) ->
    `contact.ContactResult`."""


def _from_pymunk_backend(name: str) -> Callable:
    """`pymunk_backend.<name>`, imported when first called."""

    def call(*args, **kwargs):
        from tether_gym.physics import pymunk_backend

        return getattr(pymunk_backend, name)(*args, **kwargs)

    call.__name__ = call.__qualname__ = name
    return call


MODELS: dict[str, Model] = {
    model.name: model
    for model in (
        Model("impulse", False, impulse_bounce, impulse_kernel, impulse_contact),
        Model("hybrid", True, hybrid_bounce, hybrid_kernel, hybrid_contact),
        Model(
            "pymunk",
            True,
            _from_pymunk_backend("pymunk_bounce"),
            _from_pymunk_backend("pymunk_kernel"),
            pymunk_contact,
        ),
    )
}
"""name -> `Model`: "impulse" (closed form), "hybrid" (spring tether), "pymunk" (the hybrid
model's tether in the pymunk engine, the reference)."""
DYNAMICS = tuple(MODELS)
"""The models' names in `MODELS`' order: a model's code in a compiled kernel is its index here."""
IMPULSE, HYBRID, PYMUNK = (DYNAMICS.index(name) for name in ("impulse", "hybrid", "pymunk"))
"""The dynamics codes every env kernel reads (one table: `DYNAMICS`)."""
