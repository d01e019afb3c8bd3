"""Rectangle packing on shelves: the lightmap atlas places its charts with it, the denoiser
its cut-out charts."""
from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def shelf_pack(cell_w, cell_h, order, padding, shelf_width):
    """Place rectangles of cell_w x cell_h texels (C,) on shelves in the given order (tallest
    first), `padding` empty texels between rectangles and around the border.
    Returns x, y (C,) i64 top-left corners and the used width and height."""
    x_at = np.zeros(cell_w.shape[0], np.int64)
    y_at = np.zeros(cell_w.shape[0], np.int64)
    x, y, shelf_h, used_w = padding, padding, 0, 0
    for c in order:
        if x > padding and x + cell_w[c] + padding > shelf_width:
            y += shelf_h + padding
            x, shelf_h = padding, 0
        x_at[c], y_at[c] = x, y
        x += cell_w[c] + padding
        shelf_h = max(shelf_h, cell_h[c])
        used_w = max(used_w, x)
    return x_at, y_at, used_w, y + shelf_h + padding
