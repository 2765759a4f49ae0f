"""Every default uros applies, in one place (the CLI shows them; the planners use them)."""

from __future__ import annotations

from pathlib import Path

DISTRO = "humble"  # the STM32H7 and ESP32-S3 guides uros grew from both build humble
PLATFORM = "generate_lib"  # a library for any MCU; the only platform uros creates
PRESET = "default"  # the workspace distro's colcon.meta preset, else DISTRO's
CLONE_JOBS = 4  # parallel git clones in create-firmware
# Every command's -w/--workspace: the nearest folder upward from the current one that holds a
# uros.yaml (as west finds its topdir), else FIRMWARE_DIR (what create-firmware makes by default).
WORKSPACE_MARKER = "uros.yaml"
FIRMWARE_DIR = Path("firmware")
WORKSPACE_HELP = f"nearest folder upward with {WORKSPACE_MARKER}, else ./{FIRMWARE_DIR}"
# What every micro-ROS firmware links, whatever messages it uses: `uros build --packages` and
# `--for-firmware` add those of them the workspace has (colcon adds their dependencies).
# Every output's record of its build (output/buildinfo.py reads and writes it; an ESP-IDF build folder
# holding one is a uros output, not an IDF build).
BUILD_INFO = "build-info.json"
CORE_PACKAGES = ("rcl", "rclc", "rmw_microxrcedds", "micro_ros_utilities")
# How long an HTTP team cache may stay silent (output/team_cache.py), unless $UROS_CACHE_TIMEOUT says
CACHE_TIMEOUT_SECONDS = 60.0
