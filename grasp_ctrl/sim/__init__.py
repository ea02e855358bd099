"""The mock world: simulated hand, arm, objects, table and BioTac sensors."""
