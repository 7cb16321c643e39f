# Flank Toolpath tool preset: tapered end mill (catalogue entry 'taper 1.0deg D1.0 L10'), dimensions in mm.
import bpy
bpy.ops.flank.tool_preset(taper_deg=1.0, tip_diameter_mm=1.0, flute_length_mm=10.0, shank_diameter_mm=4.0, overall_length_mm=50.0)
