"""The fingertip reference point used for contact and task-space motion.

The pad point lies on the BioTac surface model (cylinder of radius 5.5 mm about
the sensor x axis) under the central pad electrodes; its outward normal is -z
of the sensor frame (the pad faces -z, DESIGN.md 4).
"""

from __future__ import annotations

import numpy as np

PAD_POINT_SENSOR = np.array([-0.003, 0.0, -5.5e-3])
PAD_NORMAL_SENSOR = np.array([0.0, 0.0, -1.0])
PAD_POINT_SENSOR.setflags(write=False)
PAD_NORMAL_SENSOR.setflags(write=False)
