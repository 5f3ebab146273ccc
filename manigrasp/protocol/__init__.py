"""Trial protocols: phases, success criteria and failure modes of one trial."""

from manigrasp.protocol.result import PHASES, GraspMetrics, Status, TrialResult

__all__ = ["PHASES", "GraspMetrics", "Status", "TrialResult"]
