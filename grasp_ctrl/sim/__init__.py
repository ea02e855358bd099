"""The simulated worlds: MuJoCo, the reference world (``mujoco/``), the mock world, a test double
(``mock/``), and the BioTac sensor model both read (``biotac/``); the World protocol they share
(``world_api.py``), the per-trial variation profiles (``variation.py``) and the oracle that reads a
world's true forces (``oracle.py``)."""
