"""colcon"""
