"""Each cylinder's share: its strength against the cylinders it can be told from, with its errors.

The reference of a cylinder is the mean of the cylinders of its own bank that fire alike (within
:data:`ALIKE` of the bank's median strength), itself excluded; an in-line engine is one bank.  On a V
the two banks' levels are told apart only at the orders where each bank's cylinders add up, and there
the inertia torque, known to a share of itself, dominates: one bank stronger than the other by tens of
per cent fits as well as two banks alike (on a V16 of the validation population, seed 300047, one
standard error of 0.36 against 0.02 to 0.04 for the differences inside a bank).  Against its own
bank a cylinder's share carries none of that.

Cylinders that fire too nearly together (:data:`TOGETHER`; a V whose bank angle is near a multiple of
its banks' firing interval fires its cylinders in such pairs) differ at every order used by so little
a phase that the crank speed hardly tells one from the other: their difference is unknown, their sum
well known.  Such a group is judged as one: its members' mean against the mean of the cylinders
outside every group that fire alike, of both banks (a pair holds one cylinder of each, so the banks'
level cancels), or where every cylinder is in a group, against the other groups that fire alike; its
members are left out of the others' references.
"""

from __future__ import annotations

import math

import numpy as np

from monitor.types import FloatArray

__all__ = ["ALIKE", "TOGETHER", "fire_together", "one_of", "relative_shares"]

ALIKE = 0.15  # cylinders within this fraction of the median strength form the reference [-]
#: Two cylinders whose firing phases differ by less than this at the highest order the cylinder balance
#: uses are hardly told apart by the crank speed: their columns differ by under ``2 sin(TOGETHER / 2)``
#: (0.77) of a column at that order and by proportionally less at every lower one [rad].
TOGETHER = math.radians(45.0)


def fire_together(
    firing_angles: FloatArray, cycle_revolutions: int, highest_order: float
) -> list[tuple[int, ...]]:
    """The groups of cylinders (indices, ascending) that fire too nearly together to be told apart.

    Two cylinders ``d`` apart in their firing angles (on the cycle) differ at order ``k`` by the phase
    ``k d``: under :data:`TOGETHER` at ``highest_order`` they are together; groups join those together
    through any member.

    Parameters
    ----------
    firing_angles : ndarray
        Each cylinder's firing angle [rad].
    cycle_revolutions : int
        Revolutions per working cycle (1 or 2) [-].
    highest_order : float
        The highest crank-speed order the balance uses [-].

    Returns
    -------
    list of tuple of int
        Groups of two or more cylinders, in order of their first member.
    """
    cycle = 2 * math.pi * cycle_revolutions
    angles = np.mod(np.asarray(firing_angles, dtype=np.float64), cycle)
    n = angles.size
    root = list(range(n))

    def find(a: int) -> int:
        while root[a] != a:
            a = root[a]
        return a

    for a in range(n):
        for b in range(a + 1, n):
            apart = abs(float(angles[a] - angles[b]))
            if min(apart, cycle - apart) * highest_order < TOGETHER:
                root[find(b)] = find(a)
    groups: dict[int, list[int]] = {}
    for c in range(n):
        groups.setdefault(find(c), []).append(c)
    return sorted(tuple(g) for g in groups.values() if len(g) > 1)


def _alike(strength: FloatArray, bank: np.ndarray, units: list[tuple[int, ...]]) -> np.ndarray:
    """Which cylinders are within :data:`ALIKE` of their kind's median: a single cylinder of its bank's
    single cylinders', a group's members (by the group's mean) of the groups' means."""
    n = strength.size
    mean = np.empty(n)
    kind = np.empty(n, dtype=object)
    for unit in units:
        mean[list(unit)] = strength[list(unit)].mean()
        kind[list(unit)] = bank[unit[0]] if len(unit) == 1 else "together"
    alike = np.zeros(n, dtype=bool)
    for k in set(kind):
        mine = kind == k
        median = float(np.median(mean[mine]))
        alike |= mine & (np.abs(mean - median) <= ALIKE * abs(median))
    return alike


def relative_shares(
    strength: FloatArray,
    covariance: FloatArray,
    banks: list[str] | None = None,
    together: list[tuple[int, ...]] | None = None,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Each cylinder's share against its reference (the module docstring), with two errors.

    Both errors are first order in the covariance: of the share itself, and of the contrast
    ``(s_c - reference) / reference`` with the reference's level held (a change of every strength
    alike moves it by nothing): whether the cylinder differs from the others.  A group's members
    each carry the group's share and errors.

    Parameters
    ----------
    strength : ndarray, shape (n,)
        The cylinders' strengths [-].
    covariance : ndarray, shape (n, n)
        Their covariance [-].
    banks : list of str, optional
        Each cylinder's bank (None or all alike: one bank).
    together : list of tuple of int, optional
        Groups of cylinders that fire too nearly together (:func:`fire_together`).

    Returns
    -------
    relative, relative_error, contrast_error : ndarray, shape (n,)
        [-].
    """
    n = strength.size
    if n < 2:
        error = np.sqrt(np.maximum(np.diag(covariance), 0.0))
        return np.ones(1), error, error
    bank = np.asarray(banks if banks is not None and len(banks) == n else [""] * n)
    units = [tuple(g) for g in (together or [])]
    grouped = np.zeros(n, dtype=bool)
    for g in units:
        grouped[list(g)] = True
    units += [(c,) for c in range(n) if not grouped[c]]
    single = ~grouped
    alike = _alike(strength, bank, units)
    relative, error, contrast = np.empty(n), np.empty(n), np.empty(n)
    for unit in units:
        members = np.zeros(n, dtype=bool)
        members[list(unit)] = True
        # a single cylinder against its bank's others; a group against the single cylinders of both
        # banks, or where every cylinder is in a group, against the other groups (whole, so that their
        # members' unknown differences cancel)
        mates = single & ~members & ((bank == bank[unit[0]]) if len(unit) == 1 else True)
        for candidates in (alike & mates, mates, single & ~members, alike & grouped & ~members, ~members):
            if candidates.any():
                break
        else:  # one group holds every cylinder: nothing to tell it from
            relative[members], error[members], contrast[members] = 1.0, math.inf, math.inf
            continue
        m = int(candidates.sum())
        own = np.where(members, 1.0 / len(unit), 0.0)
        value = float(own @ strength)
        reference = float(strength[candidates].mean())
        gradient = own / reference - np.where(candidates, value / (reference**2 * m), 0.0)
        difference = own / reference - np.where(candidates, 1.0 / (reference * m), 0.0)
        relative[members] = value / reference
        error[members] = math.sqrt(max(float(gradient @ covariance @ gradient), 0.0))
        contrast[members] = math.sqrt(max(float(difference @ covariance @ difference), 0.0))
    return relative, error, contrast


def one_of(together: float, size: int) -> float:
    """A group's share read as one member's, the others at the reference's: ``1 - n (1 - share)``.

    Cylinders that fire too nearly together are told apart from the others only as a group
    (the module docstring): one member at ``s`` among healthy ones reads ``(s + n - 1) / n``
    for the group, so a member at 70 % of a pair reads 85 %.  Read back as one member's, the group's
    share is judged by the same limits as a cylinder alone's.

    Parameters
    ----------
    together : float
        The group's share: its members' mean against the reference [-].
    size : int
        Its members (1: a cylinder alone, its own share).

    Returns
    -------
    float
        [-].
    """
    return together if size == 1 else 1.0 - size * (1.0 - together)
