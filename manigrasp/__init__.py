"""manigrasp: a MuJoCo-based simulated grasping benchmark.

The package is layered (see DESIGN.md): pure math (`contact`, `grasp`), assets
(`objects`, `hands`), simulation (`sim`, `control`), planning (`planners`),
evaluation (`protocol`) and the harness (`bench`, `record`, `perception`).
"""

__version__ = "0.1.0"
