"""Reading a recording back: which entities it holds, its `sim_time` range, the trial's final status.

Uses rerun's chunk reader (`rerun.chunk.RrdReader`, rerun >= 0.32), so no
viewer or server is needed.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from manigrasp.errors import ManigraspError
from manigrasp.record import layout

_TRIAL_PROPERTIES = "/__properties/trial"


@dataclass(frozen=True)
class RecordingSummary:
    """What a `.rrd` recording holds.

    Attributes:
        path: the file.
        recording_id: rerun recording id (the trial id for a trial recording).
        entities: entity paths with data, sorted (leading "/").
        time_range: (first, last) `sim_time` [s], or None if nothing was logged over time.
        properties: the recording's "trial" properties (status, detail, sim_time_s, trial_id) as text.
        n_blueprints: blueprints stored in the file.
    """

    path: Path
    recording_id: str
    entities: tuple[str, ...]
    time_range: tuple[float, float] | None
    properties: dict[str, str]
    n_blueprints: int

    @property
    def status(self) -> str | None:
        """The trial's final status, or None (a plan recording, or a trial that never ended)."""
        return self.properties.get("status")


def _first(value: object) -> str:
    while isinstance(value, list) and value:
        value = value[0]
    return str(value)


def summarize(path: str | Path) -> RecordingSummary:
    """Read `path` and summarise it (`ManigraspError` if it is not a readable recording)."""
    from rerun.chunk import RrdReader

    path = Path(path)
    try:
        reader = RrdReader(path)
        recordings = reader.recordings()
        chunks = reader.stream().to_chunks() if recordings else []
        n_blueprints = len(reader.blueprints())
    except Exception as exc:  # rerun raises plain ValueError / OSError / its own types
        raise ManigraspError(f"cannot read recording {path}: {exc}") from exc
    entities, low, high, props = set(), float("inf"), float("-inf"), {}
    for chunk in chunks:
        if chunk.entity_path.startswith("/__properties"):
            if chunk.entity_path == _TRIAL_PROPERTIES:
                batch = chunk.to_record_batch().to_pydict()
                props = {k: _first(v) for k, v in batch.items() if not k.startswith("rerun.")}
            continue
        entities.add(chunk.entity_path)
        if layout.TIMELINE in chunk.timeline_names:
            ns = chunk.to_record_batch().column(layout.TIMELINE).cast("int64").to_numpy(zero_copy_only=False)
            if len(ns):
                low, high = min(low, 1e-9 * float(ns.min())), max(high, 1e-9 * float(ns.max()))
    recording_id = recordings[0].recording_id if recordings else ""
    return RecordingSummary(path=path, recording_id=str(recording_id), entities=tuple(sorted(entities)),
                            time_range=(low, high) if high >= low else None, properties=props,
                            n_blueprints=n_blueprints)
