"""Koopman models with control: a lifted linear system fitted by extended DMD (``koopman``)."""

from neckid.models.koopman.model import KoopmanEDMD, KoopmanSimulator

__all__ = ["KoopmanEDMD", "KoopmanSimulator"]
