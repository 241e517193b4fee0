"""`sortsim cycle`: ABB's Cycle 1 (25-305-25 mm, 90 deg of axis 4) run in physics."""

from __future__ import annotations

import argparse
import json

ABB_CYCLES_PER_MIN = {0.1: 150, 1.0: 150, 3.0: 115}
"""ABB's ratings of the IRB 360-3/1130 on Cycle 1 [cycles/min] by payload [kg]."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of `sortsim cycle`."""
    parser.add_argument("--payload", type=float, default=1.0, help="payload mass [kg] (0 to 3)")
    parser.add_argument("--json", action="store_true", help="print one JSON object")


def main(args: argparse.Namespace) -> int:
    """Runs Cycle 1 with the payload and prints its figures (or one JSON object)."""
    from sim.evaluation.cycle1 import run_cycle1

    report = run_cycle1(args.payload)
    if args.json:
        print(json.dumps(report.as_dict()))
        return 0
    abb = ABB_CYCLES_PER_MIN.get(round(report.payload_kg, 3))
    abb_text = f" (ABB: {abb}/min)" if abb else ""
    torques = ", ".join(f"{t:.1f}" for t in report.peak_torque_nm)
    print(f"Cycle 1 (25-305-25 mm, 90 deg axis 4, 2 x 35 ms vacuum), payload {args.payload:g} kg")
    planned = report.planned_cycle_time_s
    print(f"  cycle time        {report.cycle_time_s:.4f} s (planned {planned:.4f} s)")
    print(f"  cycles per minute {report.cycles_per_min:.1f}{abb_text}")
    print(
        f"  peak motor torque {torques} N m of {report.torque_limit_nm:.0f} N m "
        f"({100 * report.peak_torque_ratio:.0f} %)"
    )
    print(
        f"  TCP tracking error at pick {report.tracking_error_pick_mm:.3f} mm, "
        f"at place {report.tracking_error_place_mm:.3f} mm, "
        f"peak while moving {report.peak_tracking_error_mm:.3f} mm"
    )
    print(f"  axis 4 error at the stops {report.axis4_error_at_stops_deg:.2f} deg")
    print(f"  platform tilt     {report.platform_tilt_max_rad:.2e} rad (max)")
    print(
        f"  payload held      {'yes' if report.payload_held else 'NO'} "
        f"(moved {report.payload_slip_mm:.3f} mm from its welded pose)"
    )
    verdict = "would hold it" if report.vacuum_cup_holds else "would LOSE it"
    print(
        f"  vacuum cup        peak load {report.payload_peak_load_n:.0f} N of "
        f"{report.vacuum_cup_budget_n:.0f} N: the cell's cup {verdict}"
    )
    return 0
