"""Gravity, the one value every world, controller and statics check uses."""

GRAVITY_M_S2 = 9.81  # m/s^2, downward along the world's -z (the MuJoCo scene's gravity too)
