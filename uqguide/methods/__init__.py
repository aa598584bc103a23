"""Uncertainty-propagation methods, above ``pce``.

The contract is ``base`` (a method designs its runs and estimates statistics from them); each
other module is one method, registered by name in ``uqguide.config.registry``.
"""
