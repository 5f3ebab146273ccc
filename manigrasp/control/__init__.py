"""Controllers of the floating hand and its fingers: small classes over a `sim.FloatingBase` view.

- `NativeImpedance`: the impedance realised by MuJoCo's PD servos on the base
  joints (no Python per step; what the protocols use).
- `ImpedanceController`: Cartesian impedance of the TCP computed in Python every
  step (per-axis TCP-frame K, D; feed-forward; gravity compensation; optional
  adaptive stiffness); the position part of the hybrid controllers below.
- `HybridController`: selection-matrix hybrid position/force control (PI with anti-windup).
- `GuardedApproach`: approach that stops pushing at a contact-force threshold.
- `GripController`: close on position until contact, then regulate the grip force.
- `FingerClose`: close a dexterous hand finger by finger until each touches, then regulate the grip force.
- `FingerHold`: after closing, hold a hand's finger servos around the grasp they reached (stiff against opening).
"""

from manigrasp.control.fingers import FingerClose
from manigrasp.control.hold import FingerHold
from manigrasp.control.hybrid import ForceGains, ForcePI, GripController, GuardedApproach, HybridController
from manigrasp.control.impedance import AdaptiveStiffness, ImpedanceController, ImpedanceGains, default_gains
from manigrasp.control.native import BaseKinematics, NativeImpedance, euler_xyz

__all__ = [
    "AdaptiveStiffness",
    "BaseKinematics",
    "FingerClose",
    "FingerHold",
    "ForceGains",
    "ForcePI",
    "GripController",
    "GuardedApproach",
    "HybridController",
    "ImpedanceController",
    "ImpedanceGains",
    "NativeImpedance",
    "default_gains",
    "euler_xyz",
]
