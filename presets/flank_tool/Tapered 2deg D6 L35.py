# Flank Toolpath tool preset: tapered end mill (catalogue entry 'taper 2.0deg D6.0 L35'), dimensions in mm.
import bpy
bpy.ops.flank.tool_preset(taper_deg=2.0, tip_diameter_mm=6.0, flute_length_mm=35.0, shank_diameter_mm=10.0, overall_length_mm=90.0)
