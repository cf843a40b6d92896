"""gyrotest: gyro test-bench logs to an IEEE-952-style specification sheet."""

__version__ = "0.1.0"
