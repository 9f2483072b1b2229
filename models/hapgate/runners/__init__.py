"""Simulation runners: cocotb runner glue and testbench helpers, native Verilator harnesses,
the firmware co-simulation. Imports `base`, `golden` and `flows`."""
