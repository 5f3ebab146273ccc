"""Entity paths of a trial recording and the blueprint it opens with.

    world/                          3D: table, object, hand bodies, contacts, planned grasp
    world/<prefix>/<body>           a body's pose over `sim_time` (world frame)
    world/<prefix>/<body>/visual    its drawn meshes; .../collision its collision geoms
    world/contacts                  hand contact points (green: inside the friction cone, red: outside)
    world/contacts/force            force of the hand on the other geom, as arrows
    world/plan/grasp, /pregrasp     planned TCP frames; world/plan/contacts (+ /normals)
    plots/...                       scalars over `sim_time`
    trial/phase                     phase as a state lane (StateChange) and trial/log as a text log
    trial/status, trial/plan        final status and the plan's metrics (markdown)
"""

from __future__ import annotations

import rerun.blueprint as rrb

TIMELINE = "sim_time"

CONTACTS = "world/contacts"
CONTACT_FORCES = "world/contacts/force"
PLAN = "world/plan"
PLAN_GRASP = "world/plan/grasp"
PLAN_PREGRASP = "world/plan/pregrasp"
PLAN_CONTACTS = "world/plan/contacts"
PLAN_NORMALS = "world/plan/contacts/normals"

GRIP_FORCE = "plots/grip_force"
DISPLACEMENT = "plots/in_hand/displacement_mm"
ROTATION = "plots/in_hand/rotation_deg"
PERTURB_FORCE = "plots/perturb_force"

PHASE = "trial/phase"
LOG = "trial/log"
STATUS = "trial/status"
PLAN_METRICS = "trial/plan"


def trial_blueprint(hidden: list[str], title: str = "trial") -> rrb.Blueprint:
    """3D view of `world` (entities in `hidden` off by default) beside the scalar plots, phase lane and status."""
    overrides = {path: rrb.EntityBehavior(visible=False) for path in hidden}
    view3d = rrb.Spatial3DView(origin="/world", name=title, overrides=overrides)
    plots = rrb.Vertical(
        rrb.TimeSeriesView(origin="/plots/grip_force", name="grip force [N]"),
        rrb.TimeSeriesView(origin="/plots/in_hand", name="object in hand [mm, deg]"),
        rrb.TimeSeriesView(origin="/plots/perturb_force", name="perturbation force [N]"),
        rrb.StateTimelineView(origin="/trial/phase", name="phase"),
        rrb.Tabs(rrb.TextDocumentView(origin="/trial/status", name="status"),
                 rrb.TextDocumentView(origin="/trial/plan", name="plan"),
                 rrb.TextLogView(origin="/trial/log", name="log")),
        row_shares=[2, 2, 2, 1, 2],
    )
    return rrb.Blueprint(rrb.Horizontal(view3d, plots, column_shares=[3, 2]),
                         rrb.TimePanel(timeline=TIMELINE), collapse_panels=False)


def plan_blueprint() -> rrb.Blueprint:
    """The 3D view of a planner's candidates."""
    return rrb.Blueprint(rrb.Horizontal(rrb.Spatial3DView(origin="/world", name="candidates"),
                                        rrb.TextDocumentView(origin="/plan", name="ranking"), column_shares=[3, 1]))
