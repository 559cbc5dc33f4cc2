"""The modular world's experiments (thesis 5.1), on the world of `robocompose.modular` and its plug-ins: the
evolutionary baselines (`baselines`), EG-GAN and the learned baselines (`generative`, as `robocompose.teams.
generative`), the real-time protocol of Table 5.1 (`protocol`), the designs read from tables (`table_designs`), the
pool-size and terrain studies (`pool_size`, `terrain_study`) and the stages' figures (`figure_5_1`, `pictures`)."""
