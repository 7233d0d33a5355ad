"""Pictures of armlab results: scope plots, robot drawings and animations, the HTML report.

This package sits at the edge: it imports the library, the library never imports it.
Everything renders off-screen (matplotlib's Agg backend).
"""

from armlab.viz.drawing import Plane, RobotArtist, draw_robot, frame_poses

__all__ = ["Plane", "RobotArtist", "draw_robot", "frame_poses"]
