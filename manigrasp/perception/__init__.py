"""Perception in the loop: a simulated depth camera, object recognition and pose estimation.

Modules: `camera` (intrinsics, poses, ray-cast or rendered depth), `noise`
(depth noise and dropout), `cloud` (back-projection, segmentation, table
removal, normals), `features` (FPFH), `registration` (RANSAC + ICP),
`models` (the model database), `recognition` (pose hypotheses, verification,
recognition), `metrics` (ADD, ADD-S, rotation and translation errors) and
`pipeline` (one view end to end).

Open3D is an optional dependency (the `perception` extra): it is imported
only inside the functions that need it, so `import manigrasp.perception`
works without it; `camera`, `noise` and `metrics` never need it.
"""
