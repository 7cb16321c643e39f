# Flank Toolpath tool preset: tapered end mill (catalogue entry 'taper 5.0deg D4.0 L16'), dimensions in mm.
import bpy
bpy.ops.flank.tool_preset(taper_deg=5.0, tip_diameter_mm=4.0, flute_length_mm=16.0, shank_diameter_mm=8.0, overall_length_mm=60.0)
