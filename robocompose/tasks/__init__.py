"""Tasks: the four terrains of RoboGrammar (flat, frozen lake, ridged, wall) as pybullet scenes."""
