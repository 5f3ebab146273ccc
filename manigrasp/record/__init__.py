"""Rerun recordings of trials and plans: watch any trial after the fact (headless by default).

    >>> from manigrasp.record import TrialRecorder
    >>> recorder = TrialRecorder(run_dir / "recordings" / "trial.rrd", recording_id=trial_id)
    >>> result = protocol.run(scene, candidate, rng, object_pose=rest, observer=recorder)
"""

from manigrasp.record.recorder import RecordOptions, SimClock, TrialRecorder
from manigrasp.record.streams import APPLICATION_ID

__all__ = ["APPLICATION_ID", "RecordOptions", "SimClock", "TrialRecorder"]
