# Flank Toolpath tool preset: tapered end mill (catalogue entry 'taper 5.0deg D6.0 L20'), dimensions in mm.
import bpy
bpy.ops.flank.tool_preset(taper_deg=5.0, tip_diameter_mm=6.0, flute_length_mm=20.0, shank_diameter_mm=10.0, overall_length_mm=70.0)
