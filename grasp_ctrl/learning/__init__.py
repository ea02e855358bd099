"""Learning side of grasp_ctrl (optional, ``pip install .[train]``).

Datasets of tactile samples with force labels from three sources (rigid-ft,
ball-ft, planar-pushing), trial-wise splits, the paper's networks and losses,
training, metrics and ONNX export. torch is only imported by the modules that
need it (models, losses, train, export), never by the core application.
"""
