"""Hands built from the gripper models that ship inside the installed robosuite package.

The XML and meshes are read from the installed package at load time (never
copied into manigrasp) and adapted to manigrasp's conventions: see `source`
for the fixes every model needs and the per-hand modules for the rest.
"""
