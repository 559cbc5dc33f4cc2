from robocompose.io.quiet import quiet_pybullet

quiet_pybullet()  # this package imports pybullet: its C banner to /dev/null, before any module of it runs
