"""Tasks: the four terrains of RoboGrammar (flat, frozen lake, ridged, wall) as pybullet scenes."""

from robocompose.io.quiet import quiet_pybullet

quiet_pybullet()  # this package imports pybullet: its C banner to /dev/null, before any module of it runs
