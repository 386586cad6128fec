"""firmware_sim: a simulated Dynamixel X-series Protocol 2.0 bus on a pseudo-terminal."""
