"""Tests of the closed loop's package, one file per module of ``llmpas.system``."""
