"""The modular-robot world of Part II (thesis 5.1). The world itself sits at the top (`robot`, `terrain`,
`controller`, `evaluate`, `record`, the exhaustive ground truth `truth`) with the world's command line, query and
params sections (`cli`, `compose`, `params`, `eggan_params`); its plug-ins for `robocompose.search` and
`robocompose.eggan` are in `plugins/`, its experiments in `experiments/` (as `robocompose.teams` names the same
roles: `eggan_problem`, `generative`, `experiments`)."""

from robocompose.io.quiet import quiet_pybullet

quiet_pybullet()  # this package imports pybullet: without its C banner, whichever module imports it first
