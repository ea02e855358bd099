"""Device emulators used by tests, benchmarks and hardware-free runs."""
