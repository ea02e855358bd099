"""What a trial runs on: every backend by name (``registry``), the parts of one trial built from it
and stepped one tick at a time (``trial_builder``), and the real hand's rig (``hardware_rig``)."""
