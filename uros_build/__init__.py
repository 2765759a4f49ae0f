"""uros: cross-compile micro-ROS into libmicroros.a, its include tree and a CMake package."""

__version__ = "0.1.0"
