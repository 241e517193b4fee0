"""Each fault kind's colour in the timeline figures (a run's bands, a sweep's shares)."""

BAND_COLOURS = {
    "camera_outage": "tab:purple",
    "robot_stop": "tab:red",
    "belt_stop": "tab:gray",
    "vacuum_drop": "tab:orange",
    "belt_speed": "tab:cyan",
}
"""Each fault kind's band colour (`sim.config.faults.FAULT_KINDS`)."""
