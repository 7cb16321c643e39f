# Flank Toolpath tool preset: tapered end mill (catalogue entry 'taper 1.5deg D4.0 L40'), dimensions in mm.
import bpy
bpy.ops.flank.tool_preset(taper_deg=1.5, tip_diameter_mm=4.0, flute_length_mm=40.0, shank_diameter_mm=8.0, overall_length_mm=90.0)
