# Flank Toolpath tool preset: tapered end mill (catalogue entry 'taper 3.0deg D6.0 L30'), dimensions in mm.
import bpy
bpy.ops.flank.tool_preset(taper_deg=3.0, tip_diameter_mm=6.0, flute_length_mm=30.0, shank_diameter_mm=10.0, overall_length_mm=80.0)
