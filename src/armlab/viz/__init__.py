"""Pictures of armlab results: scope plots, robot drawings and animations, the HTML report.

This package sits at the edge: it imports the library, the library never imports it.
The figures use whatever matplotlib backend the user chose (the command line picks Agg);
file writers (animations) draw on their own Agg canvas.

* :func:`plot_scopes` — the scope figures of a SimulationResult as PNG/SVG files;
* :func:`draw_robot` — the robot with its links and frames Σ_base, Σ_0 … Σ_e;
* :func:`animate_robot` — a GIF (or MP4 with ffmpeg) of a joint trajectory;
* :func:`view3d` — an interactive 3-D view (plotly) of a robot or a recorded run, with
  play/pause and a time slider; :func:`write_view3d` writes it as one offline HTML file;
* :func:`armlab.viz.report.build_report` — the whole seed project as one HTML file.
"""

from armlab.viz.animation import animate_robot
from armlab.viz.drawing import Plane, RobotArtist, draw_robot, frame_poses
from armlab.viz.scopes import plot_scopes
from armlab.viz.view3d import view3d, write_view3d

__all__ = ["Plane", "RobotArtist", "animate_robot", "draw_robot", "frame_poses", "plot_scopes", "view3d",
           "write_view3d"]
