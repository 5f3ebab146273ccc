"""`manigrasp hands list|show`: the registered hands and what each declares."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from manigrasp import hands
from manigrasp.cli.output import format_table, print_json
from manigrasp.errors import ManigraspError
from manigrasp.hands.base import Hand

_HEADERS = ["name", "kind", "DoF", "TCP site", "approach", "closing", "finger bodies",
            "max width [mm]", "max grip [N]", "mass [kg]"]


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    """Register `hands` and its sub-commands."""
    parser = subparsers.add_parser("hands", help="list and inspect hand models",
                                   description="The registered hands (a user hand is named package.module:attr).")
    sub = parser.add_subparsers(dest="hands_command", metavar="SUBCOMMAND", required=True)

    p = sub.add_parser("list", help="every registered hand: kind, DoF, TCP frame, fingers, width, force, mass")
    p.add_argument("--json", action="store_true", help="print a JSON list instead of a table")
    p.set_defaults(func=_list)

    p = sub.add_parser("show", help="one hand's metadata, actuators and notes")
    p.add_argument("name", help="registered hand name or package.module:attribute")
    p.add_argument("--json", action="store_true", help="print JSON instead of text")
    p.set_defaults(func=_show)


def summary(hand: Hand) -> dict[str, Any]:
    """The `hands list` record of one hand (lengths in m, forces in N, masses in kg)."""
    return {
        "name": hand.name, "kind": hand.kind, "actuated_dof": hand.n_actuators, "tcp_site": hand.tcp_site,
        "approach_axis": list(hand.approach_axis), "closing_axis": list(hand.closing_axis),
        "finger_bodies": list(hand.finger_bodies), "max_width": float(hand.max_width),
        "max_grip_force": float(hand.max_grip_force), "mass": float(hand.mass),
    }


def _axis(axis: list[float]) -> str:
    labels = {(1.0, 0.0, 0.0): "+x", (0.0, 1.0, 0.0): "+y", (0.0, 0.0, 1.0): "+z",
              (-1.0, 0.0, 0.0): "-x", (0.0, -1.0, 0.0): "-y", (0.0, 0.0, -1.0): "-z"}
    return labels.get(tuple(float(v) for v in axis), str(axis))


def _row(record: dict[str, Any]) -> list[str]:
    return [record["name"], record["kind"], str(record["actuated_dof"]), record["tcp_site"],
            _axis(record["approach_axis"]), _axis(record["closing_axis"]), ", ".join(record["finger_bodies"]),
            f"{1000 * record['max_width']:.1f}", f"{record['max_grip_force']:.1f}", f"{record['mass']:.3f}"]


def _list(args: argparse.Namespace) -> int:
    records, failures = [], []
    for name in hands.names():
        try:
            records.append(summary(hands.load(name)))
        except ManigraspError as exc:
            failures.append(f"manigrasp: error: hand {name!r} does not load: {exc}")
    if args.json:
        print_json(records)
    else:
        print(format_table(_HEADERS, [_row(r) for r in records]))
    for line in failures:
        print(line, file=sys.stderr)
    return 2 if failures else 0


def _show(args: argparse.Namespace) -> int:
    hand = hands.load(args.name)
    info = summary(hand) | {
        "root_body": hand.root_body, "actuators": list(hand.actuators),
        "open_ctrl": hand.open_ctrl, "closed_ctrl": hand.closed_ctrl,
        "source": hand.source, "notes": list(hand.notes),
    }
    if args.json:
        print_json(info)
        return 0
    for key, value in info.items():
        if key == "notes":
            print("notes:")
            for note in value:
                print(f"  - {note}")
        else:
            print(f"{key}: {value}")
    return 0
