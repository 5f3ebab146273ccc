"""The standard protocol's friction coefficients and gravity, in one place.

`SceneConfig` takes its hand and table defaults from here (override them there,
per run); the table's and the hand's torsional/rolling terms, the objects' own
geoms and the planners' contact model use the same values. The weight m g of an
object (the protocols' loads, the planners' and the hands' capacity estimates)
uses `STANDARD_GRAVITY`, the scene's default gravity.
"""

STANDARD_GRAVITY = 9.81  # [m/s^2] g_0: the scenes' default gravity and every load given in units of m g

STANDARD_MU = 0.5  # [-] sliding friction: hand-object, hand-table, table, object geoms
STANDARD_TORSION_M = 0.005  # [m] torsional friction: hand geoms (soft finger), table, object geoms
STANDARD_ROLLING_M = 0.0001  # [m] rolling friction of every hand, table and object geom
