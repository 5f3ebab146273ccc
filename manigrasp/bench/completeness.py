"""Is a run complete? The trials its config (run.json) enumerates against the trials its store holds.

An interrupted run holds fewer; its report says so before any figure (`manigrasp.bench.markdown.warning_lines`),
since every rate of it is over the stored trials only.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from manigrasp.bench.store import TrialKey
from manigrasp.protocol.result import TrialResult


@dataclass(frozen=True)
class Completeness:
    """How many of the trials that a run's config enumerates are stored (an interrupted run holds fewer).

    Attributes:
        expected: trials the config in run.json enumerates; -1 when they could not be enumerated (`note`).
        stored: of those, the stored ones.
        unexpected: stored trials the config does not enumerate.
        partial: "group (k of n)" for each group with some of its trials stored ("object/hand/planner/observation/
            protocol", as in trial ids).
        not_run: groups with none of their trials stored.
        note: why the check could not be made ("" when it was).
    """

    expected: int
    stored: int
    unexpected: int = 0
    partial: tuple[str, ...] = ()
    not_run: tuple[str, ...] = ()
    note: str = ""

    @property
    def complete(self) -> bool:
        """True if every enumerated trial is stored (and nothing else)."""
        return self.expected >= 0 and self.stored == self.expected and not self.unexpected

    def warning(self) -> str:
        """One line for a reader ("" when the run is complete): what is missing, and that rates are over the
        stored trials only."""
        if self.complete:
            return ""
        if self.expected < 0:
            return f"completeness not checked: {self.note}"
        parts = [f"incomplete run: {self.stored} of the {self.expected} trials of its config are stored"]
        for groups, how in ((self.partial, "partly run"), (self.not_run, "not run")):
            if groups:
                shown = ", ".join(groups[:3]) + (f" and {len(groups) - 3} more" if len(groups) > 3 else "")
                parts.append(f"{len(groups)} group(s) {how}: {shown}")
        if self.unexpected:
            parts.append(f"{self.unexpected} stored trial(s) the config does not enumerate")
        return "; ".join(parts) + (". Every rate is over the stored trials only; re-run the same `manigrasp bench` "
                                   "command to finish it")


def completeness(results: list[tuple[TrialKey, TrialResult]], meta: dict, base: Path | None = None) -> Completeness:
    """Compare the stored trials with those that the run's config (``meta["config"]``, run.json) enumerates;
    `base`: the config file's folder (run.json's ``config_dir``), for relative mesh paths."""
    from manigrasp.bench.config import parse_config
    from manigrasp.bench.trials import groups
    from manigrasp.errors import ManigraspError

    stored = {key for key, _ in results}  # keys, not id strings: compared field by field
    try:
        enumerated = [[g.key(i) for i in range(g.n_grasps)]
                      for g in groups(parse_config(meta["config"], where="run.json"), base)]
    except (ManigraspError, KeyError, TypeError) as exc:
        return Completeness(-1, len(stored), note=f"the run's config could not be enumerated ({exc})")
    expected = {key for keys in enumerated for key in keys}
    partial, not_run = [], []
    for keys in enumerated:
        k = sum(key in stored for key in keys)
        name = keys[0].trial_id.rpartition("/")[0]
        if k == 0:
            not_run.append(name)
        elif k < len(keys):
            partial.append(f"{name} ({k} of {len(keys)})")
    return Completeness(len(expected), len(stored & expected), len(stored - expected), tuple(partial),
                        tuple(not_run))
