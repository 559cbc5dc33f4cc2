"""Control: RoboGrammar's MPPI controller over a pybullet robot world."""
