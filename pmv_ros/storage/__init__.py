"""Files in and out, below every other layer: bounded reading, strict JSON, rosbag2 recordings.

Imports no other part of the package.
"""
