"""Multi-robot team formation (thesis 5.2): terrain chips, Voronoi regions, ergodic coverage, NSGA-II."""
