"""Shared dynamics: relative orbital motion, attitude kinematics, integrators."""
