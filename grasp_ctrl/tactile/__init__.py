"""Tactile signals: frame layout, sensor geometry, taring and contact gating."""
