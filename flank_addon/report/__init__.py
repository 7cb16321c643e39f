"""Report content without Blender: the geometry, camera and legend of the report picture, and the error
chart along the flank profile.  The Blender scene that renders a report lives in the extension's
``operators/report_scene.py``."""
