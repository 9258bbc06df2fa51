"""gcode-opt: re-time FDM G-code with the energy/inertia-optimal law of motion."""
__version__ = "0.1.0"
