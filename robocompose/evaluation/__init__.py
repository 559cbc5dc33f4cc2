"""Evaluating grammar designs: the robot evaluator (MPPI on a task), its references and its fidelity ladder."""
