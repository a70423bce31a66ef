"""What fuzzynav takes from pymunk beyond its public API, in one place, checked.

The control loop runs tens of thousands of steps a second, where every pymunk property
read builds a ``Vec2d``. The hot path therefore calls the Chipmunk functions pymunk's
properties call, through pymunk's own cffi binding (``pymunk._chipmunk``), on the
pointers pymunk keeps (``Body._body``, ``Space._space``), and repeats ``Space.step``'s
bookkeeping around the bare Chipmunk step (its private ``_locked``, ``_add_later``...).

All of it is read here, for the pymunk major version it was written for
(:data:`SUPPORTED_MAJOR`); on any other version, or if a name is missing, :data:`FAST`
is False and the world takes the public API (the same numbers, more slowly).
``tests/test_compat.py`` fails loudly when the installed pymunk of the supported major
version lacks one of these names, so an upgrade that moves them is seen at once.
"""

from __future__ import annotations

from typing import Any

import pymunk

__all__ = [
    "SUPPORTED_MAJOR",
    "installed_major",
    "SPACE_STEP_STATE",
    "FAST",
    "ffi",
    "lib",
    "body_pointer",
    "space_pointer",
    "can_step_fast",
    "step_space",
    "shape_count",
    "forget_removed_shapes",
    "cpBodyGetAngle",
    "cpBodyGetPosition",
    "cpBodySetAngularVelocity",
    "cpBodySetPosition",
    "cpBodySetVelocity",
    "cpSpaceSegmentQueryFirst",
]

#: The pymunk major version whose private names are used.
SUPPORTED_MAJOR = "7"
#: ``Space.step``'s own bookkeeping, which :func:`step_space` repeats.
SPACE_STEP_STATE = (
    "_locked",
    "_removed_shapes",
    "_add_later",
    "_remove_later",
    "_post_step_callbacks",
    "_bodies_to_check",
    "threaded",
)

try:  # pymunk's own cffi binding of Chipmunk: the calls its properties make, minus Vec2d.
    from pymunk import _chipmunk as _binding
except ImportError:  # pragma: no cover - a pymunk without it takes the public-API path
    _binding = None
ffi: Any = getattr(_binding, "ffi", None)
lib: Any = getattr(_binding, "lib", None)


def installed_major() -> str:
    """The installed pymunk's major version (``pymunk.version``; pymunk 7.0.0 put
    Chipmunk's "2.0.0" there, so a mismatch is checked against the package's metadata)."""
    major = pymunk.version.split(".")[0]
    if major != SUPPORTED_MAJOR:
        from importlib.metadata import version

        major = version("pymunk").split(".")[0]
    return major


#: The fast path is there: the binding imports and the version is the supported one.
FAST = lib is not None and installed_major() == SUPPORTED_MAJOR

# Looking a function up on the cffi lib costs as much as a short call: bound once.
cpBodyGetAngle: Any = lib.cpBodyGetAngle if FAST else None
cpBodyGetPosition: Any = lib.cpBodyGetPosition if FAST else None
cpBodySetAngularVelocity: Any = lib.cpBodySetAngularVelocity if FAST else None
cpBodySetPosition: Any = lib.cpBodySetPosition if FAST else None
cpBodySetVelocity: Any = lib.cpBodySetVelocity if FAST else None
cpSpaceSegmentQueryFirst: Any = lib.cpSpaceSegmentQueryFirst if FAST else None
_cpSpaceStep: Any = lib.cpSpaceStep if FAST else None


def body_pointer(body: pymunk.Body) -> Any:
    """Chipmunk's ``cpBody *`` of ``body``, or None without the fast path.

    Parameters
    ----------
    body : pymunk.Body
        A body.
    """
    return getattr(body, "_body", None) if FAST else None


def space_pointer(space: pymunk.Space) -> Any:
    """Chipmunk's ``cpSpace *`` of ``space``, or None without the fast path.

    Parameters
    ----------
    space : pymunk.Space
        A space.
    """
    return getattr(space, "_space", None) if FAST else None


def can_step_fast(space: pymunk.Space) -> bool:
    """Whether :func:`step_space` can step ``space`` itself (else it calls Space.step).

    Parameters
    ----------
    space : pymunk.Space
        A space.
    """
    return space_pointer(space) is not None and all(
        hasattr(space, name) for name in SPACE_STEP_STATE
    )


def step_space(space: pymunk.Space, pointer: Any, dt_s: float) -> None:
    """``space.step(dt_s)``: the same Chipmunk step (collision detection and the contact
    callbacks included) with pymunk's bookkeeping around it, minus ~1.5 us of Python per
    call. Anything unusual (bodies to check, a threaded space) takes ``Space.step``.

    Parameters
    ----------
    space : pymunk.Space
        The space (:func:`can_step_fast` true for it).
    pointer : cffi pointer
        Its :func:`space_pointer`.
    dt_s : float
        The step, s.
    """
    if space._bodies_to_check or space.threaded:
        space.step(dt_s)
        return
    space._locked = True  # adds and removes from callbacks wait, as in Space.step
    try:
        _cpSpaceStep(pointer, dt_s)
        space._removed_shapes.clear()
    finally:
        space._locked = False
    if space._add_later or space._remove_later or space._post_step_callbacks:
        # Queued during the step: finish as Space.step does, with the public API.
        added = list(space._add_later)
        space._add_later.clear()
        space.add(*added)
        removed = set()
        while space._remove_later:
            obj, _ = space._remove_later.popitem()
            if obj not in removed:
                removed.add(obj)
                space.remove(obj)
        for key in list(space._post_step_callbacks):
            space._post_step_callbacks[key](space)
        space._post_step_callbacks.clear()


def shape_count(space: pymunk.Space) -> int | None:
    """How many shapes ``space`` holds, without building ``space.shapes`` (a list); None
    when this pymunk keeps them otherwise.

    Parameters
    ----------
    space : pymunk.Space
        A space.
    """
    shapes = getattr(space, "_shapes", None)
    return None if shapes is None else len(shapes)


def forget_removed_shapes(space: pymunk.Space) -> None:
    """Let go of the shapes removed from ``space`` since its last step.

    ``Space`` keeps every removed shape until its next ``step()`` (for the callbacks of a
    step in progress): resets or scenario loads without a step in between kept them all
    (300 viewer Resets among 200 obstacles: 60,000 shapes and 58 MB). Outside a
    step nothing needs them. Nothing happens inside a step, or on a pymunk that keeps
    them otherwise.

    Parameters
    ----------
    space : pymunk.Space
        A space, not stepping.
    """
    removed = getattr(space, "_removed_shapes", None)
    if isinstance(removed, dict) and not getattr(space, "_locked", False):
        removed.clear()
