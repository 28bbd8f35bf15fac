"""Sweeps: a grid of runs (configs × grid overrides × seeds) driven as Ray tasks into one store.

`plan` turns the command line into typed entries (pure); `worker` drives one entry as a normal
run of the store (a Ray task); `driver` submits the entries, shows progress from the store and
stops cleanly on Ctrl-C.
"""
