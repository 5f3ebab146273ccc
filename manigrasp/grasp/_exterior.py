"""A small exterior algebra on R^d, batched, for enumerating hyperplanes.

A k-vector of R^d is stored by its C(d, k) components on the basis
e_S = e_{s1} ^ ... ^ e_{sk}, S running over the sorted k-subsets of
range(d) in `itertools.combinations` order. The wedge of k row vectors has
component S equal to the k x k minor of those rows on columns S, so the wedge
of d - 1 rows, turned into a vector by `hodge_vector`, is orthogonal to all
of them (the generalised cross product). Wedges are bilinear maps with fixed
sign tables, so a batch of them is a pair of matrix products.
"""

from __future__ import annotations

import itertools
from functools import cache

import numpy as np


@cache
def subsets(d: int, k: int) -> tuple[tuple[int, ...], ...]:
    """The sorted k-subsets of range(d), in basis order."""
    return tuple(itertools.combinations(range(d), k))


@cache
def wedge_table(d: int, k: int, j: int) -> np.ndarray:
    """(C(d,k), C(d,j), C(d,k+j)) signs with (a ^ b)_C = sum_AB T[A,B,C] a_A b_B."""
    index = {s: i for i, s in enumerate(subsets(d, k + j))}
    table = np.zeros((len(subsets(d, k)), len(subsets(d, j)), len(index)))
    for ia, a in enumerate(subsets(d, k)):
        for ib, b in enumerate(subsets(d, j)):
            if set(a).isdisjoint(b):
                inversions = sum(x > y for x in a for y in b)
                table[ia, ib, index[tuple(sorted(a + b))]] = (-1.0) ** inversions
    table.setflags(write=False)
    return table


@cache
def _right_table(d: int, k: int, j: int) -> np.ndarray:
    """`wedge_table` laid out (C(d,j), C(d,k) * C(d,k+j)) for contracting the right factor first."""
    table = wedge_table(d, k, j)
    out = np.ascontiguousarray(table.transpose(1, 0, 2).reshape(table.shape[1], -1))
    out.setflags(write=False)
    return out


def wedge_rows(rows: np.ndarray) -> np.ndarray:
    """Wedge of the k rows of each matrix: (..., k, d) -> (..., C(d, k))."""
    d = rows.shape[-1]
    out = rows[..., 0, :]
    for i in range(1, rows.shape[-2]):
        table = wedge_table(d, i, 1)
        y = (rows[..., i, :] @ _right_table(d, i, 1)).reshape(*out.shape, table.shape[2])
        out = np.einsum("...a,...ac->...c", out, y)
    return out


def wedge_outer(a: np.ndarray, b: np.ndarray, d: int, k: int, j: int) -> np.ndarray:
    """Wedge of every pair: a (B, Na, C(d,k)), b (B, Nb, C(d,j)) -> (B, Na*Nb, C(d,k+j)).

    Pairs are ordered with the index into `a` varying slowest. A 0-vector
    (k or j = 0) is a scalar with one component. The sign table is contracted
    first with whichever side makes the two matrix products cheaper.
    """
    table = wedge_table(d, k, j)
    ca, cb, cc = table.shape
    batch, na, nb = a.shape[0], a.shape[1], b.shape[1]
    if na * cb * (ca + nb) <= nb * ca * (cb + na):
        x = (a @ table.reshape(ca, cb * cc)).reshape(batch, na, cb, cc)
        return (b[:, None] @ x).reshape(batch, na * nb, cc)
    y = (b @ _right_table(d, k, j)).reshape(batch, nb, ca, cc)
    y = y.transpose(0, 2, 1, 3).reshape(batch, ca, nb * cc)
    return (a @ y).reshape(batch, na * nb, cc)


def hodge_vector(top: np.ndarray) -> np.ndarray:
    """(..., d) vector orthogonal to the d-1 rows whose wedge is `top` (..., d)."""
    # Subset j of size d-1 (combinations order) omits index d-1-j, and the
    # null vector is x_i = (-1)^i det(rows without column i).
    d = top.shape[-1]
    signs = (-1.0) ** np.arange(d)
    return top[..., ::-1] * signs
