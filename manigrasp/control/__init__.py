"""Controllers of the floating hand and its fingers: small classes over a `sim.FloatingBase` view.

- `ImpedanceController`: Cartesian impedance of the TCP (per-axis TCP-frame K, D;
  feed-forward; gravity compensation; optional adaptive stiffness).
- `HybridController`: selection-matrix hybrid position/force control (PI with anti-windup).
- `GuardedApproach`: approach that stops pushing at a contact-force threshold.
- `GripController`: close on position until contact, then regulate the grip force.
"""

from manigrasp.control.hybrid import ForceGains, ForcePI, GripController, GuardedApproach, HybridController
from manigrasp.control.impedance import AdaptiveStiffness, ImpedanceController, ImpedanceGains, default_gains

__all__ = [
    "AdaptiveStiffness",
    "ForceGains",
    "ForcePI",
    "GripController",
    "GuardedApproach",
    "HybridController",
    "ImpedanceController",
    "ImpedanceGains",
    "default_gains",
]
