"""The MuJoCo world, the reference world: the scene built from the hand and object files, the
contact reading, the world's hand and sensor backends, and MuJoCo's log."""
