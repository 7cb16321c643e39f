# Flank Toolpath tool preset: tapered end mill (catalogue entry 'taper 3.0deg D4.0 L20'), dimensions in mm.
import bpy
bpy.ops.flank.tool_preset(taper_deg=3.0, tip_diameter_mm=4.0, flute_length_mm=20.0, shank_diameter_mm=8.0, overall_length_mm=65.0)
