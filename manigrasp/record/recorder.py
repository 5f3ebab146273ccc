"""`TrialRecorder`: a `TrialObserver` that writes one trial to a rerun `.rrd` file.

    >>> recorder = TrialRecorder("trial.rrd", recording_id="box/parallel_jaw/0003")
    >>> result = protocol.run(scene, candidate, rng, object_pose=rest, observer=recorder)
    >>> recorder.close()        # idempotent; `on_end` already closed it

It only reads the scene. Samples are buffered and written as columns at the
end (one `send_columns` per entity), so a sample costs a contact read-out and
a few array copies. Time is the trial's simulated time on the `sim_time`
timeline, kept increasing across the scene resets some protocols do inside a
trial. A failure inside the recorder never reaches the protocol: it is kept
in `error`, the recorder stops, and the caller decides what to do with it.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np
import rerun as rr

from manigrasp.errors import ConfigError
from manigrasp.geometry import pose_distance, pregrasp_pose
from manigrasp.protocol.execution import object_in_hand
from manigrasp.protocol.grasp import PREGRASP_OFFSET
from manigrasp.protocol.result import Phase, Status, TrialResult
from manigrasp.record import layout, static
from manigrasp.record.geometry import body_entity
from manigrasp.record.streams import open_file_stream, release_streams
from manigrasp.sim import HandContacts, grip_force, read_hand_contacts


@dataclass(frozen=True)
class RecordOptions:
    """What a trial recording holds and how densely.

    Attributes:
        rate_hz: samples per simulated second (default 60); `full_rate(timestep)`: every physics step.
        collision: also log collision geoms of bodies that have visual meshes (hidden in the viewer).
        force_scale: length of a contact force arrow per newton [m/N].
        contact_radius: radius of a drawn contact point [m].
        frame_length: axis length of the planned grasp frames [m].
        pregrasp_offset: distance of the drawn pre-grasp frame behind the grasp, along its approach axis [m]
            when the grasp names none (the protocol's `pregrasp_offset`; a grasp's own offset is drawn as
            the protocol executes it; display only).
    """

    rate_hz: float = 60.0
    collision: bool = True
    force_scale: float = 0.002
    contact_radius: float = 0.003
    frame_length: float = 0.05
    pregrasp_offset: float = PREGRASP_OFFSET

    @classmethod
    def full_rate(cls, timestep: float, **fields: Any) -> RecordOptions:
        """Options sampling every physics step of `timestep` [s] (e.g. `scene.model.opt.timestep`)."""
        return cls(rate_hz=1.0 / timestep, **fields)

    def __post_init__(self) -> None:
        if not self.rate_hz > 0:
            raise ConfigError(f"rate_hz must be > 0, got {self.rate_hz}")
        for name in ("force_scale", "contact_radius", "frame_length"):
            if not getattr(self, name) > 0:
                raise ConfigError(f"{name} must be > 0, got {getattr(self, name)}")


class SimClock:
    """Trial time [s] from `scene.time`, increasing across resets of the scene within a trial.

    Events before the first sample (the scene may still hold the previous
    trial's state) are at 0. A later drop of `scene.time` is a reset: the time
    reached before it is added to all later stamps.
    """

    def __init__(self) -> None:
        self.offset, self.last, self.started = 0.0, 0.0, False

    def stamp(self, raw: float, sample: bool) -> float:
        """The trial time of an event at `scene.time` = `raw` [s] (`sample`: an `on_sample` call)."""
        if not self.started:
            if not sample:
                return 0.0
            self.started = True
        elif raw < self.last - 1e-12:
            self.offset += self.last
        self.last = raw
        return self.offset + raw


@dataclass
class _Samples:
    """Buffered time series of one trial."""

    time: list[float] = field(default_factory=list)
    pos: list[np.ndarray] = field(default_factory=list)
    quat: list[np.ndarray] = field(default_factory=list)
    contact_pos: list[np.ndarray] = field(default_factory=list)
    contact_force: list[np.ndarray] = field(default_factory=list)
    contact_ok: list[np.ndarray] = field(default_factory=list)
    grip: list[float] = field(default_factory=list)
    perturb: list[np.ndarray] = field(default_factory=list)
    hand_time: list[float] = field(default_factory=list)
    displacement_mm: list[float] = field(default_factory=list)
    rotation_deg: list[float] = field(default_factory=list)


def _guarded(method: Callable[..., None]) -> Callable[..., None]:
    """Run an observer callback; on an exception keep it in `self.error` and stop recording."""

    @functools.wraps(method)
    def wrapper(self: TrialRecorder, *args: Any, **kwargs: Any) -> None:
        if self.error is not None or self.closed:
            return
        try:
            method(self, *args, **kwargs)
        except Exception as exc:  # noqa: BLE001 - a recording must never change a trial: kept, reported by the caller
            self.error = exc.with_traceback(None)  # its frames would keep the stream (and its threads) alive
            self._disconnect()

    return wrapper


class TrialRecorder:
    """Records one trial into `path` (a `TrialObserver`; see the module docstring).

    Args:
        path: the `.rrd` file to write (its folder must exist).
        recording_id: rerun recording id (the trial id).
        candidate: the planner's `GraspCandidate`, for its metrics in the plan panel (optional).
        options: what to record (default `RecordOptions()`).
    """

    def __init__(self, path: str | Path, *, recording_id: str = "trial", candidate: Any = None,
                 options: RecordOptions | None = None) -> None:
        self.path, self.recording_id, self.candidate = Path(path), recording_id, candidate
        self.options = options or RecordOptions()
        self.sample_period_s = 1.0 / self.options.rate_hz
        self.result: TrialResult | None = None
        self.error: Exception | None = None
        self.closed = False
        self._stream: rr.RecordingStream | None = None
        self._clock = SimClock()
        self._samples = _Samples()
        self._bodies = np.zeros(0, int)
        self._entities: list[str] = []
        self._is_object_geom = np.zeros(0, bool)
        self._grasped, self._reference = False, None

    # -------------------------------------------------------------- observer
    @_guarded
    def on_start(self, scene: Any, grasp: Any, object_pose: Any) -> None:  # noqa: D102 - TrialObserver
        meshes, hidden = static.scene_geometry(scene.model)
        stream = open_file_stream(self.path, self.recording_id, layout.trial_blueprint(hidden, self.recording_id))
        self._stream = stream
        stream.send_recording_name(self.recording_id)
        static.log_geometry(stream, meshes, self.options.collision)
        object_body = [scene.object_body] if scene.object_body >= 0 else []
        self._bodies = np.array([*object_body, *scene.hand_bodies], int)
        self._entities = [body_entity(scene.model, int(b)) for b in self._bodies]
        self._is_object_geom = np.zeros(scene.model.ngeom, bool)
        self._is_object_geom[scene.object_geoms] = True
        self._log_plan(grasp)
        stream.log(layout.CONTACTS, rr.Points3D.from_fields(radii=[self.options.contact_radius]), static=True)
        stream.log(layout.PERTURB_FORCE, rr.SeriesLines(names=["x", "y", "z"]), static=True)
        stream.log(layout.DISPLACEMENT, rr.SeriesLines(names=["displacement [mm]"]), static=True)
        stream.log(layout.ROTATION, rr.SeriesLines(names=["rotation [deg]"]), static=True)
        stream.set_time(layout.TIMELINE, duration=0.0)
        stream.log(layout.LOG, rr.TextLog(f"start {self.recording_id}", level="INFO"))

    @_guarded
    def on_phase(self, scene: Any, phase: Phase, detail: str = "") -> None:  # noqa: D102 - TrialObserver
        if self._stream is None:
            return
        phase = Phase(phase)
        t = self._clock.stamp(scene.time, sample=False)
        if phase.grasped and not self._grasped:  # the grasp is made: motion in the hand counts from here
            self._reference = object_in_hand(scene)
        self._grasped = phase.grasped
        label = f"{phase} {detail}".strip()
        self._stream.set_time(layout.TIMELINE, duration=t)
        self._stream.log(layout.PHASE, rr.StateChange(state=label))
        self._stream.log(layout.LOG, rr.TextLog(f"phase: {label}", level="INFO"))

    @_guarded
    def on_sample(self, scene: Any) -> None:  # noqa: D102 - TrialObserver
        if self._stream is not None:
            self._sample(scene, self._clock.stamp(scene.time, sample=True))

    @_guarded
    def on_end(self, scene: Any, result: TrialResult) -> None:  # noqa: D102 - TrialObserver
        self.result = result
        if self._stream is None:
            return
        t = self._clock.stamp(scene.time, sample=self._clock.started)
        samples = self._samples
        if self._clock.started and (not samples.time or t > samples.time[-1]) and scene.is_finite():
            self._sample(scene, t)
        self._finish(result, t)
        self._disconnect()

    # ------------------------------------------------------------ lifecycle
    def close(self, result: TrialResult | None = None) -> None:
        """Write what is buffered and close the file (idempotent). Without `on_end` (the trial raised),
        `result` is recorded as the final status if given."""
        if self.closed:
            return
        if self._stream is not None and self.error is None and self.result is None:
            try:
                self.result = result
                self._finish(result, self._samples.time[-1] if self._samples.time else 0.0)
            except Exception as exc:  # noqa: BLE001 - reported through `error`
                self.error = exc
        self._disconnect()

    def _disconnect(self) -> None:
        if self._stream is not None:
            self._stream.flush()
            self._stream.disconnect()
            self._stream = None  # the last reference: rerun now sees the stream as orphaned
            release_streams()
        self.closed = True

    # ------------------------------------------------------------- internals
    def _log_plan(self, grasp: Any) -> None:
        from manigrasp.protocol.grasp import as_grasp, check_grasp, grasp_tcp_pose

        g = as_grasp(grasp)
        problem = check_grasp(g)
        pose = None if problem else grasp_tcp_pose(g)
        offset = self.options.pregrasp_offset if g.pregrasp_offset is None else g.pregrasp_offset
        pregrasp = None if pose is None else pregrasp_pose(pose, offset)  # where the protocol starts the hand
        static.log_planned_grasp(self._stream, pose, pregrasp, np.asarray(g.contacts, float).reshape(-1, 3),
                                 np.asarray(g.contact_normals, float).reshape(-1, 3), self.options.frame_length)

    def _sample(self, scene: Any, t: float) -> None:
        s, data = self._samples, scene.data
        s.time.append(t)
        s.pos.append(data.xpos[self._bodies].copy())
        s.quat.append(data.xquat[self._bodies].copy())
        if data.ncon:
            contacts = read_hand_contacts(scene, "any")
            s.contact_pos.append(contacts.position)
            s.contact_force.append(contacts.force)
            s.contact_ok.append(contacts.in_cone)
            s.grip.append(grip_force(_subset(contacts, self._is_object_geom[contacts.other_geom])))
        else:
            s.contact_pos.append(np.zeros((0, 3)))
            s.contact_force.append(np.zeros((0, 3)))
            s.contact_ok.append(np.zeros(0, bool))
            s.grip.append(0.0)
        if scene.object_body >= 0:
            s.perturb.append(data.xfrc_applied[scene.object_body, :3].copy())
        if self._reference is not None:
            shift, angle = pose_distance(self._reference, object_in_hand(scene))
            s.hand_time.append(t)
            s.displacement_mm.append(1000.0 * shift)
            s.rotation_deg.append(angle)

    def _finish(self, result: TrialResult | None, t: float) -> None:
        stream = self._stream
        self._send_samples()
        stream.set_time(layout.TIMELINE, duration=t)
        status = result.status.value if result is not None else "unknown (the trial raised)"
        detail = f" ({result.detail})" if result is not None and result.detail else ""
        ok = result is not None and result.status is Status.SUCCESS
        stream.log(layout.PHASE, rr.StateChange(state=f"end: {status}"))
        stream.log(layout.LOG, rr.TextLog(f"end: {status}{detail}", level="INFO" if ok else "WARN"))
        if result is not None:
            stream.log(layout.STATUS, rr.TextDocument(static.markdown_table(f"{status}{detail}",
                                                                            static.status_rows(result)),
                                                      media_type="text/markdown"), static=True)
            stream.log(layout.PLAN_METRICS, rr.TextDocument(static.markdown_table(
                "planned grasp", static.plan_rows(result, self.candidate)), media_type="text/markdown"), static=True)
        stream.send_property("trial", rr.AnyValues(status=status, detail=detail.strip(" ()") or "-",
                                                   sim_time_s=float(t), trial_id=self.recording_id))

    def _send_samples(self) -> None:
        s, stream = self._samples, self._stream
        if not s.time:
            return
        index = [rr.TimeColumn(layout.TIMELINE, duration=np.asarray(s.time))]
        pos, quat = np.stack(s.pos), static.xyzw(np.stack(s.quat))
        for j, entity in enumerate(self._entities):
            stream.send_columns(entity, index,
                                rr.Transform3D.columns(translation=pos[:, j], quaternion=quat[:, j]))
        lengths = [len(p) for p in s.contact_pos]
        points, forces = np.concatenate(s.contact_pos).reshape(-1, 3), np.concatenate(s.contact_force).reshape(-1, 3)
        colors = np.where(np.concatenate(s.contact_ok)[:, None], static.IN_CONE, static.OUT_OF_CONE).astype(np.uint8)
        stream.send_columns(layout.CONTACTS, index,
                            rr.Points3D.columns(positions=points, colors=colors).partition(lengths))
        stream.send_columns(layout.CONTACT_FORCES, index, rr.Arrows3D.columns(
            origins=points, vectors=self.options.force_scale * forces, colors=colors).partition(lengths))
        stream.send_columns(layout.GRIP_FORCE, index, rr.Scalars.columns(scalars=np.asarray(s.grip)))
        if s.perturb:
            stream.send_columns(layout.PERTURB_FORCE, index, rr.Scalars.columns(scalars=np.stack(s.perturb)))
        if s.hand_time:
            hand_index = [rr.TimeColumn(layout.TIMELINE, duration=np.asarray(s.hand_time))]
            stream.send_columns(layout.DISPLACEMENT, hand_index, rr.Scalars.columns(scalars=s.displacement_mm))
            stream.send_columns(layout.ROTATION, hand_index, rr.Scalars.columns(scalars=s.rotation_deg))


def _subset(contacts: HandContacts, mask: np.ndarray) -> HandContacts:
    """The contacts where `mask` (n,) is True (e.g. those with the object, for the grip force)."""
    return HandContacts(**{f.name: getattr(contacts, f.name)[mask] for f in fields(HandContacts)})
