"""The planner's forward pass of one input through ContactNet, compiled with numba.

``NumpyContactNet._forward`` makes it four small matrix products and their additions and ReLUs in numpy: about
eleven calls of a microsecond of dispatch each for 55,000 multiply-adds (Solo12's trot network, 14-128-128-128-162),
9-10 us of the planner's three evaluations a plan. Here the layers are straight loops over the same float32
weights, the inner loop along a weight row (which LLVM vectorizes), eight inputs per pass over a layer's outputs
(one load and store of each partial sum per eight products instead of per product): about 3.3 us a pass on Go2's
trot network (4.2 us with one input a pass). Each sum still runs input by input, in index order
(``tests/test_network.py`` asks for the very floats of that plainest form), so the scores differ from numpy's
(BLAS's order) by rounding only (a few 1e-7 relative; checked against the numpy form as well). Compiled on first
use, cached next to this file.
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
        n_in, n_out = w.shape[0], w.shape[1]
        i = 0
        while i + 8 <= n_in:  # eight inputs a pass over the outputs, each sum still in input order
            x0, x1, x2, x3, x4, x5, x6, x7 = h[i], h[i + 1], h[i + 2], h[i + 3], h[i + 4], h[i + 5], h[i + 6], h[i + 7]
            w0, w1, w2, w3, w4, w5, w6, w7 = w[i], w[i + 1], w[i + 2], w[i + 3], w[i + 4], w[i + 5], w[i + 6], w[i + 7]
            for j in range(n_out):
                nxt[j] = (((((((nxt[j] + x0 * w0[j]) + x1 * w1[j]) + x2 * w2[j]) + x3 * w3[j]) + x4 * w4[j])
                           + x5 * w5[j]) + x6 * w6[j]) + x7 * w7[j]
            i += 8
        while i < n_in:
            x = h[i]
            for j in range(n_out):
                nxt[j] += x * w[i, j]
            i += 1
        if layer < last:
            for j in range(n_out):
                if nxt[j] < 0.0:
                    nxt[j] = 0.0
        h = nxt
    for j in range(out.shape[0]):
        out[j] = h[j]


__all__ = ["forward_one"]
