"""Built-in trajectories as editable TOML files (installed as ``bhr.trajectories``).

Copy one, change its numbers, and pass the copy with ``bhr follow --traj PATH``.
"""
