"""The virtual device: plant (motors, linkage, hand), scenes and the closed-loop runner.
Imports `base`, `golden`, `flows` and `runners`."""
