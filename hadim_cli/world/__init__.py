"""The simulated worlds: the rover's room (paper §3.1) and the arm's table.

`environment.make_world(config)` builds the configured body's world (`world.World`,
`arm.ArmWorld`); `layout`, `actions`, `scene`, `placement` and `kinematics` are light (numpy
only) and safe to import anywhere; `physics`, `arm_physics`, `environment`, `world`, `arm` and
`bench` import pymunk, `render` imports matplotlib.
"""
