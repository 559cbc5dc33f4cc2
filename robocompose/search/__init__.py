"""Generic evolutionary search on a small problem interface (`problem.Problem`): GA, deterministic crowding, random
sampling, and the niching metric; NSGA-II (pymoo) on a `nsga2.GenomeProblem` with hypervolume. The modular-robot
world, the team-formation world and the EG-GAN issue plug their problems in."""
