"""Composition learning for modular robots (GLSO and EG-GAN) as a reproducible pipeline."""

__version__ = "0.1.0"
