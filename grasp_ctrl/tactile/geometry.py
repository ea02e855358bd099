"""BioTac electrode geometry in the sensor frame (metres).

Sensor frame (docs/design.md 4): x toward the tip, the pad faces -z. Positions are
the published electrode coordinates of the BioTac (given in mm in the product
documentation); normals are the outward electrode orientations used by the
analytic model of Lin et al. (2013).
"""

from __future__ import annotations

import numpy as np

_POS_MM = np.array(
    [
        [0.993, -4.855, -1.116],
        [-2.700, -3.513, -3.670],
        [-6.200, -3.513, -3.670],
        [-8.000, -4.956, -1.116],
        [-10.500, -3.513, -3.670],
        [-13.400, -4.956, -1.116],
        [4.763, 0.000, -2.330],
        [3.031, -1.950, -3.330],
        [3.031, 1.950, -3.330],
        [1.299, 0.000, -4.330],
        [0.993, 4.855, -1.116],
        [-2.700, 3.513, -3.670],
        [-6.200, 3.513, -3.670],
        [-8.000, 4.956, -1.116],
        [-10.500, 3.513, -3.670],
        [-13.400, 4.956, -1.116],
        [-2.800, 0.000, -5.080],
        [-9.800, 0.000, -5.080],
        [-13.600, 0.000, -5.080],
    ]
)

_NORMALS = np.array(
    [
        [0.196, -0.956, -0.220],
        [0.000, -0.692, -0.722],
        [0.000, -0.692, -0.722],
        [0.000, -0.976, -0.220],
        [0.000, -0.692, -0.722],
        [0.000, -0.976, -0.220],
        [0.500, 0.000, -0.866],
        [0.500, 0.000, -0.866],
        [0.500, 0.000, -0.866],
        [0.500, 0.000, -0.866],
        [0.196, 0.956, -0.220],
        [0.000, 0.692, -0.722],
        [0.000, 0.692, -0.722],
        [0.000, 0.976, -0.220],
        [0.000, 0.692, -0.722],
        [0.000, 0.976, -0.220],
        [0.000, 0.000, -1.000],
        [0.000, 0.000, -1.000],
        [0.000, 0.000, -1.000],
    ]
)

#: (19, 3) electrode positions, sensor frame, millimetres (the published numbers).
ELECTRODE_POSITIONS_MM: np.ndarray = _POS_MM
#: (19, 3) electrode positions, sensor frame, metres. Computed as mm / 1000.0,
#: bit-for-bit the authors' conversion, so voxel edges derived from it match theirs.
ELECTRODE_POSITIONS_SENSOR: np.ndarray = _POS_MM / 1000.0
#: (19, 3) outward unit normals of the electrodes, sensor frame.
ELECTRODE_NORMALS_SENSOR: np.ndarray = _NORMALS / np.linalg.norm(_NORMALS, axis=1, keepdims=True)
#: Radius of the sensor surface model (cylinder about x, hemispherical cap for x > 0).
SURFACE_RADIUS_M = 5.5e-3

ELECTRODE_POSITIONS_MM.setflags(write=False)
ELECTRODE_POSITIONS_SENSOR.setflags(write=False)
ELECTRODE_NORMALS_SENSOR.setflags(write=False)
