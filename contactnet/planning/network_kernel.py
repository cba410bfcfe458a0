"""The planner's forward pass of one input through ContactNet, compiled with numba.

``NumpyContactNet._forward`` makes it four small matrix products and their additions and ReLUs in numpy: about
eleven calls of a microsecond of dispatch each for 55,000 multiply-adds (Solo12's trot network, 14-128-128-128-162),
9-10 us of the planner's three evaluations a plan. Here the layers are straight loops over the same float32
weights, the inner loop along a weight row (which LLVM vectorizes): about 4 us. The sums run input by input, in
index order, so the scores differ from numpy's (BLAS's order) by rounding only (a few 1e-7 relative;
``tests/test_network.py`` checks them against the numpy form). Compiled on first use, cached next to this file.
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True, nogil=True)
def forward_one(u: np.ndarray, weights: tuple, biases: tuple, out: np.ndarray) -> None:
    """Fills ``out`` (n_out,) with the network's output for the input ``u`` (n_in,): ``weights`` the layers'
    transposed weights (in, out), ``biases`` theirs (out,), all of ``u``'s dtype; ReLU after every layer but the
    last. The caller makes ``out`` (an array made here would be boxed on return)."""
    h = u.copy()
    last = len(weights) - 1
    for layer in range(len(weights)):
        w = weights[layer]
        nxt = biases[layer].copy()
        for i in range(w.shape[0]):
            x = h[i]
            for j in range(w.shape[1]):
                nxt[j] += x * w[i, j]
        if layer < last:
            for j in range(nxt.shape[0]):
                if nxt[j] < 0.0:
                    nxt[j] = 0.0
        h = nxt
    for j in range(out.shape[0]):
        out[j] = h[j]


__all__ = ["forward_one"]
