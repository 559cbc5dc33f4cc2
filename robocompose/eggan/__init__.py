"""EG-GAN (thesis Part II): an evolution-guided, task-conditioned generator over a problem interface."""
