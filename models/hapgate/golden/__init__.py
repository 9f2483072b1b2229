"""Golden models: bit-exact integer models of every RTL block, their float truth, the signal
generator, kinematics, the register map and register-file model, the bus and PC-link codecs.
Imports only `hapgate.base` (and numpy); nothing here needs a simulator."""
