"""The application: scenarios, controls, simulation runs, recording, the command line, mesh fitting
and the benchmark suite.  It may import everything below it (ellipsim.mujoco, ellipsim.core)."""
