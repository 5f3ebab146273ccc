"""The standard protocol's friction coefficients, in one place.

`SceneConfig` takes its hand and table defaults from here (override them there,
per run); the table's and the hand's torsional/rolling terms, the objects' own
geoms and the planners' contact model use the same values.
"""

STANDARD_MU = 0.5  # [-] sliding friction: hand-object, hand-table, table, object geoms
STANDARD_TORSION_M = 0.005  # [m] torsional friction: hand geoms (soft finger), table, object geoms
STANDARD_ROLLING_M = 0.0001  # [m] rolling friction of every hand, table and object geom
