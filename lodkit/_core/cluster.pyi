"""Type stubs for lodkit._core.cluster (Cython): the per-cell passes of lodkit.cluster."""

import numpy as np

def cell_sums(P: np.ndarray, F: np.ndarray, label: np.ndarray, n_cells: int,
              quadrics: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Summed positions (k, 3), vertex counts (k,) and, with ``quadrics``, the summed
    area-weighted face quadrics (k, 11: a11 a12 a13 a22 a23 a33 b1 b2 b3 c w) per cell;
    P (n, 3) float64, F (m, 3) int32, label (n,) int64."""

def place_quadric(Q: np.ndarray, mean: np.ndarray, cell_lo: np.ndarray, h: float,
                  regularise: float, steps: int) -> np.ndarray:
    """(k, 3) quadric minimisers by iterated Tikhonov towards ``mean``, clamped to the cell
    boxes [cell_lo, cell_lo + h]."""

def quadric_errors(Q: np.ndarray, X: np.ndarray) -> np.ndarray:
    """(k,) Q(x) / w per cell (0 where w = 0)."""

def most_important(P: np.ndarray, F: np.ndarray, label: np.ndarray,
                   n_cells: int) -> tuple[np.ndarray, np.ndarray]:
    """Per cell the vertex of largest Rossignac-Borrel weight (longest incident edge times
    the spread of the incident face normals), and the (n,) weights."""

def nearest_vertex(P: np.ndarray, label: np.ndarray, X: np.ndarray) -> np.ndarray:
    """Per cell the vertex nearest its row of X (ties: the lower index)."""
