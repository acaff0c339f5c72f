"""The physics floor: the formulae of MODEL.md by topic, as small numba functions the step loops
inline, and the scene-building models of loads.

- ``structure``: storey forces, damping power, the structure's energy ``E1``;
- ``absorbers``: the absorber laws' kind codes, parameter rows and attachment forces;
- ``impact``: the Newton impact and the sticking rule;
- ``hertz``: Hertz contact force, energy and sub-step;
- ``loads``: load kind codes and closed-form forces and envelopes;
- ``filters``, ``wind``, ``spectra``: filtered noise, wind and response spectra.

It imports nothing of the step loops (``vines_stoch.kernels``) and, of the compile floor, only
the compile options (``vines_stoch.jit.flags``).
"""
