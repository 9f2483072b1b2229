"""The PC side: the host API over a serial link (pyserial). Imports `base` and `golden` only,
so a PC program needs no simulator."""
