"""Evaluating designs: the shared evaluation cache and executor, and the robot evaluator (MPPI on a task)."""
