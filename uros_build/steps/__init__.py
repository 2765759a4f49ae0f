"""`uros build`'s steps, in the order commands/build.py runs them: start (the run, host facts),
prepare (the trees), inputs (over toolchain_file and colcon_setup: every input as a digest, the
build key), team_cache, host_stage, colcon_run, deliver (merge, verify, swap)."""
