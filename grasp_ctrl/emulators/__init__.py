"""Software stand-ins for hardware, for tests and for trying the tools without a robot."""
