"""What runs a built library: the QEMU machines, the probe and app firmware built against an output,
the QEMU + agent session (and a host ROS 2 peer), and what the firmware's console says."""
