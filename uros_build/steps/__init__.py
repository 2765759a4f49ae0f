"""`uros build`'s steps, one module each, in the order commands/build.py runs them: prepare
(the trees), inputs (toolchain, colcon command, fingerprint, build key), team_cache, colcon_run,
stage (merge, verify, swap)."""
