"""The NL coil as a circuit, built from SPEC.md §2 (eq. 41's inductance matrix) without the
package: the independent reference that the shunt stability and realisation tests compare with."""

import numpy as np

from bayes_emt.reference import PAPER_TABLES


def nl_inductance_matrix(p=PAPER_TABLES["NL"], n=5, N=480.0):
    """``(L, Rv)``: the (n+1)×(n+1) inductance matrix of coil + n ring loops
    ``[[N²(Pg + ΣP), N (DP)ᵀ], [N DP, D P Dᵀ]]`` [H] and the ring resistances ``Rv`` [Ω]."""
    Pv = np.array([p[f"P{j}"] for j in range(1, n + 1)])
    Rv = np.array([p[f"R{j}"] for j in range(1, n + 1)])
    D = np.tril(np.ones((n, n)))
    b = N * (D @ Pv)
    L = np.block([[np.array([[N**2 * (p["Pg"] + Pv.sum())]]), b[None, :]],
                  [b[:, None], D @ np.diag(Pv) @ D.T]])
    return L, Rv
