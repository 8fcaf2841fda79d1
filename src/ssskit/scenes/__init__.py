"""Procedural test signals (and, later, 3D scenes) that produce irradiance images."""

from .signals import SIGNALS, make_signal

__all__ = ["SIGNALS", "make_signal"]
