"""Potentials, geometry, point clouds and controllers for GMM-based proximity operations."""
