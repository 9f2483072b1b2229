"""pytest setup for every test under tb/: the pinned tool environment first."""

from hapgate.base import toolenv

toolenv.apply()
