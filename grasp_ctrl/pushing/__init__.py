"""Planar-pushing ground truth (paper section II-C).

A box pushed on a table by the fingertip: from its tracked pose trajectory we
recover the pusher's force f_c by least squares over the rigid-body equations,
with Coulomb friction of n particles on the footprint (uniform pressure).
"""
