"""Opening and closing rerun file streams without leaving threads behind.

rerun keeps every stream created from Python, with a batcher and a sink
thread, until a cleanup that `rr.init` also runs (rerun issue #2116), and
the blueprint stream that `RecordingStream.save(path, default_blueprint=...)`
creates internally is never released at all (measured with rerun 0.41: two
idle threads per file). A worker recording thousands of trials would pile up
thousands of threads, so here the blueprint stream is made, used and
disconnected explicitly, and orphaned streams are cleaned after each file.
This uses rerun internals pinned by the ``rerun-sdk==0.41.0`` requirement;
without them it falls back to the public `save` (correct files, leaked threads),
and tests/test_record.py counts threads to notice.
"""

from __future__ import annotations

from pathlib import Path

import rerun as rr
import rerun.blueprint as rrb

APPLICATION_ID = "manigrasp"


def open_file_stream(path: str | Path, recording_id: str, blueprint: rrb.Blueprint) -> rr.RecordingStream:
    """A recording stream writing to `path` with `blueprint` as its default layout; only `sim_time`
    and explicit timelines (no wall-clock `log_time`)."""
    from rerun import bindings

    stream = rr.RecordingStream(APPLICATION_ID, recording_id=recording_id)
    stream.set_log_time_enabled(False)
    new_blueprint = getattr(bindings, "new_blueprint", None)
    save = getattr(bindings, "save", None)
    if new_blueprint is None or save is None or not hasattr(blueprint, "_log_to_stream"):
        stream.save(path, default_blueprint=blueprint)
        return stream
    layout = rr.RecordingStream._from_native(new_blueprint(application_id=APPLICATION_ID, make_default=False,
                                                           make_thread_default=False, default_enabled=True))
    layout.set_time("blueprint", sequence=0)
    blueprint._log_to_stream(layout)
    memory = layout.memory_recording()
    save(path=str(path), default_blueprint=memory.storage, recording=stream.to_native(), write_footer=True)
    layout.disconnect()
    del layout, memory
    return stream


def release_streams() -> None:
    """Free the threads of streams that no Python object refers to any more (call after dropping one)."""
    from rerun import bindings

    cleanup = getattr(bindings, "flush_and_cleanup_orphaned_recordings", None)
    if cleanup is not None:
        cleanup()
