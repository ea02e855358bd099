"""The mock world: a hand-written test double (fast; its success rates are not results), its
step kernels, grip and shape models, and its hand and sensor backends."""
