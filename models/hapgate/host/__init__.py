"""The PC side: the host API over a serial link (pyserial). Imports `base` and `golden` only,
so a PC program needs no simulator."""

from .api import (
                  DEFAULT_TTL_MS,
                  Device,
                  DeviceFault,
                  HapticError,
                  Info,
                  LinkLost,
                  ProtocolError,
                  Refused,
                  Scene,
                  State,
                  Stats,
                  Timeout,
)

__all__ = ["DEFAULT_TTL_MS", "Device", "DeviceFault", "HapticError", "Info", "LinkLost",
           "ProtocolError", "Refused", "Scene", "State", "Stats", "Timeout"]
