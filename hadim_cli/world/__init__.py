"""The simulated room (paper §3.1).

`world.World` is the environment; `layout` and `scene` are light (numpy only) and safe to import
anywhere; `physics`, `world`, `bench` import pymunk, `render` imports matplotlib.
"""
