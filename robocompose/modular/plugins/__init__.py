"""The modular world's plug-ins: the design problem on one terrain for `robocompose.search` (`search_problem`) and
the task-conditioned problem for `robocompose.eggan` (`eggan_problem`, as `robocompose.teams.eggan_problem`)."""
