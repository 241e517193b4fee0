"""`sortsim view`: one episode shown live in MuJoCo's interactive viewer.

The episode is the one `sortsim run` would run with the same options (`--config`, `--seed`,
`--items`, `--planner`, `--perception`, ...; `sim.cli.run.add_episode_arguments`), shown in
`mujoco.viewer.launch_passive` from the video's viewpoint, with the tracked items drawn as
spheres in their predicted class's colour and the counters in the corner
(`sim.render.live_view`). It is paced to `--real-time-factor` simulated seconds per wall second
(default 1, real time; 0: as fast as the machine steps). It writes no file; at the end it prints
the episode's summary, as `sortsim run` does. Closing the window stops the episode (exit code 0,
one line with the counters so far).

Refused in one line (exit code 2) before any work: no display (`DISPLAY` unset on Linux; macOS
needs `mjpython`), a display GLFW cannot open, and everything `sortsim run` refuses of the
config and, for camera perception, of the camera's calibration and rendering back-end. Camera
perception also needs `MUJOCO_GL=egl` (or `osmesa`): the camera then renders off-screen in the
main thread beside the viewer's GLFW window, which has a thread of its own.
"""

from __future__ import annotations

import argparse

from sim.cli.run import add_episode_arguments


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of `sortsim view`: the episode's (as `sortsim run`), the pace, the panels."""
    add_episode_arguments(parser)
    parser.add_argument(
        "--real-time-factor",
        type=float,
        default=1.0,
        metavar="R",
        help="simulated seconds shown per wall-clock second (default 1: real time; 0.2: slow "
        "motion; 0: as fast as the machine steps)",
    )
    parser.add_argument(
        "--panels",
        action="store_true",
        help="show the viewer's left and right panels (their reset, keyframe and slider "
        "controls act on the running episode)",
    )


def main(args: argparse.Namespace) -> int:
    """Show one episode in the viewer, then print its summary."""
    from sim.render.live_view import check_display, check_real_time_factor

    check_display()
    check_real_time_factor(args.real_time_factor)
    from sim.cli.run import Progress, check_perception, load_config, summary

    config = load_config(args)
    if config.perception == "camera":
        from sim.render.live_view import check_camera_beside_viewer

        check_camera_beside_viewer()
    check_perception(config)
    from sim.episode.runner import config_cell, run_episode
    from sim.render.live_view import LiveView, ViewerClosed

    cell = config_cell(config, sized=True)
    view = LiveView(cell.model, cell.data, args.real_time_factor, panels=args.panels)
    progress = None if args.quiet else Progress()
    try:
        result = run_episode(config, cell=cell, progress=progress, recorder=view)
    except ViewerClosed as closed:
        if progress is not None:
            progress.done()
        print(f"window closed before the episode's end: {closed.status}")
        return 0
    if progress is not None:
        progress.done()
    print(summary(result))
    return 0
