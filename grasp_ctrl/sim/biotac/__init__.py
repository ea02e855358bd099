"""The BioTac sensor model (electrodes, pressure and vibration from contacts), its fitted
parameters, and the simulated presses the learned policies are fitted on."""
