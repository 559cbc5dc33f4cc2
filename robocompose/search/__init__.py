"""Generic evolutionary search on a small problem interface (`problem.Problem`): GA, deterministic crowding, random
sampling, and the niching metric. The modular-robot world and the EG-GAN issue plug their problems in."""
