"""Numbers the control tick and the worlds rely on: finite checks, fixed-order 3-vector arithmetic,
numpy's small sums on lists, goal limiting, optional numba compilation, and numbers parsed from
flags and text with ranges."""
