"""Cell counts and blockMesh gradings from wanted end sizes.

A segment of length ``length`` meshed with geometric cells of first size ``a`` and last size
``b`` has about ``length / mean`` cells with ``mean = (b - a) / ln(b / a)`` (the continuous
limit); blockMesh takes the ratio last/first as its grading.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class Spacing:
    """Cells along one block edge: count and blockMesh grading (a number or multi-grading)."""

    cells: int
    grading: float | list[list[float]]


def graded(length: float, first: float, last: float, min_cells: int = 2) -> Spacing:
    """Geometric cells from ``first`` to ``last`` (sizes in m) over ``length``."""
    assert length > 0 and first > 0 and last > 0
    if math.isclose(first, last, rel_tol=1e-9):
        mean = first
    else:
        mean = (last - first) / math.log(last / first)
    cells = max(min_cells, round(length / mean))
    return Spacing(cells, last / first)


def two_sided(length: float, edge: float, middle: float, min_cells: int = 4) -> Spacing:
    """Fine at both ends, coarse in the middle (blockMesh multi-grading, two halves)."""
    half = graded(length / 2, edge, middle, min_cells=max(1, min_cells // 2))
    ratio = middle / edge
    return Spacing(2 * half.cells, [[0.5, 0.5, ratio], [0.5, 0.5, 1 / ratio]])


def uniform(length: float, size: float, min_cells: int = 1) -> Spacing:
    return Spacing(max(min_cells, round(length / size)), 1.0)
