from robocompose.io.quiet import quiet_pybullet

quiet_pybullet()  # this package imports pybullet: without its C banner, whichever module imports it first
