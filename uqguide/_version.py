"""The package version: one place, imported by whatever stamps files with it."""

__version__ = "0.1.0"
