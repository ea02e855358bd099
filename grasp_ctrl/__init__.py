"""grasp_ctrl: tactile force-feedback lift-and-place grasping.

Units are SI everywhere (N, m, rad, s, kg); raw sensor values stay in counts.
Frames are named in variable names: ``f_sensor``, ``p_hand``, ``f_world``.
"""

__version__ = "0.1.0"
