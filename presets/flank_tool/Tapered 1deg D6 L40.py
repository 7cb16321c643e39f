# Flank Toolpath tool preset: tapered end mill (catalogue entry 'taper 1.0deg D6.0 L40'), dimensions in mm.
import bpy
bpy.ops.flank.tool_preset(taper_deg=1.0, tip_diameter_mm=6.0, flute_length_mm=40.0, shank_diameter_mm=8.0, overall_length_mm=90.0)
