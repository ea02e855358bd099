"""The lift-and-place controller: a transitions state machine ticked once per control cycle."""
