"""`uros build`'s steps, in the order commands/build.py runs them, each handed one frozen context
(context.py: the plan, the runner, the host facts, the target's kind chosen once in target_kind.py):
start (the run, host facts), prepare (the trees), toolchain_file, inputs (scanned sources, every
input as a digest, the build key) over colcon_setup, team_cache, host_stage, colcon_run, deliver
(merge, verify, swap)."""
