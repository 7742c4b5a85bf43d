"""The checks of the numeric keywords of the public API and of the command's numeric flags:
one rule each, named by the caller — a keyword (``step``) in the library, a flag
(``--step``) on the command line. A bad value (NaN, an infinity, a bool, a string, a number
out of range) raises :class:`tetlap.OptionError` before any work; ``threads`` is checked by
the core's one check. ``tests/test_options.py`` walks every numeric keyword of the public
API through these.

>>> from tetlap._options import positive
>>> positive(0.3, "step")
0.3
>>> positive(float("nan"), "--step")
Traceback (most recent call last):
...
tetlap.errors.OptionError: --step must be a positive number
"""

from __future__ import annotations

import functools
import math
import numbers
import warnings

from .errors import OptionError

__all__ = ["positive", "non_negative", "tolerance", "finite", "count", "threads", "at_most",
           "at_least", "flag", "weights_used", "renamed", "MAX_SECONDS", "UNWEIGHTED_KINDS"]


def _real(value) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def _finite(value) -> bool:
    """``math.isfinite``, False for an int beyond float64 (10**400) instead of raising."""
    try:
        return math.isfinite(value)
    except OverflowError:
        return False


def positive(value, name: str) -> float:
    """``value`` if it is a finite number > 0."""
    if not (_real(value) and _finite(value) and value > 0):
        raise OptionError(f"{name} must be a positive number")
    return value


def flag(value, name: str) -> bool:
    """``value`` if it is True or False (a NumPy bool too): ``"no"`` or 0 are not flags."""
    import numpy as np     # here: `tetlap --help` imports this module, and not NumPy

    if not isinstance(value, (bool, np.bool_)):
        raise OptionError(f"{name} must be True or False, got {value!r}")
    return bool(value)


def non_negative(value, name: str) -> float:
    """``value`` if it is a finite number >= 0."""
    if not (_real(value) and _finite(value) and value >= 0):
        raise OptionError(f"{name} must be a non-negative number")
    return value


def tolerance(value, name: str) -> float:
    """``value`` if it is a finite number in ``[0, 1)``: a relative tolerance (1 or more
    would accept everything)."""
    if not (_real(value) and 0 <= value < 1):
        raise OptionError(f"{name} must be a relative tolerance in [0, 1), got {value!r}")
    return value


def finite(value, name: str) -> float:
    """``value`` if it is a finite real number (a shift, a signed level)."""
    if not (_real(value) and _finite(value)):
        raise OptionError(f"{name} must be a finite real number, got {value!r}")
    return value


def count(value, name: str, least: int = 1, most: int | None = None) -> int:
    """``value`` if it is an integer >= ``least`` (1 or 0) and, if given, <= ``most``."""
    if not (isinstance(value, numbers.Integral) and not isinstance(value, bool)
            and value >= least and (most is None or value <= most)):
        if most is not None:
            raise OptionError(f"{name} must be an integer between {least} and {most}, "
                              f"got {value!r}")
        kind = {1: "a positive integer", 0: "a non-negative integer"}.get(
            least, f"an integer >= {least}")
        raise OptionError(f"{name} must be {kind}")
    return value


def threads(value, name: str = "threads"):
    """``value`` if the core accepts it as a thread count (None: all cores)."""
    from . import _core

    try:
        _core.check_options({"threads": value})
    except OptionError as e:  # None: the environment's count, named by the message
        raise OptionError(str(e) if name == "threads" or value is None
                          else f"{name}: {e}") from None
    return value


#: The longest time limit an option takes, in seconds (11.6 days): the operating system's
#: timers overflow from about 2.1e6 s (a C int of milliseconds), Python's from 9.2e9 s.
MAX_SECONDS = 1e6


def at_most(value, most, name: str):
    """``value`` (a number, already checked) if it is at most ``most``: for the options
    whose larger values overflow a timer or a float, or repeat work for ever."""
    if value > most:
        raise OptionError(f"{name} must be at most {most:g}")
    return value


def at_least(value, least, name: str):
    """``value`` (a number, already checked) if it is at least ``least``: for the sizes
    whose smaller values ask for more work or memory than any machine has."""
    if value < least:
        raise OptionError(f"{name} must be at least {least:g}")
    return value


#: The kinds whose values do not depend on vertex weights: the primal Laplacian (and the
#: affine ``t = 0``, which is the primal), the barycentric, mixed (plain circumcentres,
#: moved inside) and FEM masses. Weights move the centres of the dual: they belong to the
#: dual Laplacian (``"dual"``, every affine ``t > 0``) and the circumcentric mass.
UNWEIGHTED_KINDS = ("primal", "barycentric", "mixed", "fem")


def _centre_free(kinds) -> tuple[list, bool]:
    """The kinds asked for (None: a part not asked) and whether none of them depends on the
    dual's centres (the primal, the barycentric, mixed and fem masses, t = 0). A kind this
    rule does not know counts as depending (the core names a bad kind)."""
    asked = [k for k in kinds if k is not None]
    plain = [k for k in asked if (isinstance(k, str) and k in UNWEIGHTED_KINDS)
             or (_real(k) and k == 0)]
    return asked, bool(asked) and len(plain) == len(asked)


def _ignored(asked: list, them: str) -> str:
    what = " and ".join(repr(k) for k in asked)
    return (f"{what} {'does' if len(asked) == 1 else 'do'} not depend on {them} and would "
            f"ignore {them}: drop {them}, or ask for \"dual\" or \"circumcentric\"")


def weights_used(given: bool, kinds, name: str = "weights") -> None:
    """Refuse vertex weights (``given``) for a request none of whose ``kinds`` (the
    Laplacian and mass kinds asked for; None for a part not asked) depends on them: the
    result would ignore them silently. A kind this rule does not know passes (the core
    names a bad kind).

    >>> weights_used(True, ("dual", "barycentric"))
    >>> weights_used(True, ("primal", "barycentric"))
    Traceback (most recent call last):
    ...
    tetlap.errors.OptionError: weights: vertex weights belong to the dual ...
    """
    asked, unused = _centre_free(kinds)
    if given and unused:
        raise OptionError(
            f"{name}: vertex weights belong to the dual (they move its centres to power "
            f'centres, which the dual Laplacian, "dual" or an affine t > 0, and the '
            f"circumcentric mass use); {_ignored(asked, 'them')}")


def centres_used(boundary_centres, kinds, where: str = "") -> None:
    """Refuse ``boundary_centres="barycentric"`` for a request none of whose ``kinds``
    depends on the dual's centres, by the rule of :func:`weights_used` (the same kinds use
    both): the result would ignore it silently. ``where`` follows the keyword in the
    message (" (of this Mesh)").

    >>> centres_used("barycentric", ("dual", None))
    >>> centres_used("barycentric", ("primal", "fem"))
    Traceback (most recent call last):
    ...
    tetlap.errors.OptionError: boundary_centres="barycentric" moves the dual's centres ...
    """
    asked, unused = _centre_free(kinds)
    if boundary_centres == "barycentric" and unused:
        raise OptionError(
            f'boundary_centres="barycentric"{where} moves the dual\'s centres in tets with a '
            f'boundary face (which the dual Laplacian, "dual" or an affine t > 0, and the circumcentric '
            f"mass use); {_ignored(asked, 'it')}")


def renamed(**old_to_new: str):
    """Decorator: the keywords of a function renamed as ``old="new"`` keep working under
    their old names, with a :class:`DeprecationWarning` that names both (pointing at the
    caller's line); passing both names is a ``TypeError``, as a keyword given twice is.
    The one rule for every renamed keyword of the API.

    >>> import warnings
    >>> @renamed(size="length")
    ... def f(*, length=1.0):
    ...     return length
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     f(size=2.0), str(caught[0].message)
    (2.0, 'f(): the keyword size= is deprecated, use length= (it takes the same values)')
    """
    def decorate(f):
        name = f.__qualname__.removesuffix(".__init__")

        @functools.wraps(f)
        def wrapper(*args, **kwargs):
            for old, new in old_to_new.items():
                if old in kwargs:
                    if new in kwargs:
                        raise TypeError(f"{name}() got both {old}= (deprecated) and {new}=: "
                                        f"pass {new}= only")
                    warnings.warn(f"{name}(): the keyword {old}= is deprecated, use {new}= "
                                  "(it takes the same values)", DeprecationWarning, stacklevel=2)
                    kwargs[new] = kwargs.pop(old)
            return f(*args, **kwargs)

        return wrapper
    return decorate
