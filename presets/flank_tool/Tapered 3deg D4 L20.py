# Flank Toolpath tool preset (Tool panel > Tool Presets): tapered end mill, taper 3 deg per side, tip diameter
# 4, flute length 20, shank diameter 8, overall l ength 65 mm (diameter at the top of the flutes 6.10 mm).
# Dimensions in mm and degrees: the *_mm / *_deg settings convert them to the scene's unit (a unit-less
# scene counts as mm), so the tool has the same size whatever the unit and unit scale.
import bpy
settings = bpy.context.scene.flank_settings

settings.tool_kind = 'CONE'
settings.sf_shape = 'alpha'
settings.tool_taper_deg = 3
settings.tool_tip_diameter_mm = 4
settings.tool_flute_length_mm = 20
settings.tool_shank_diameter_mm = 8
settings.tool_shank_length_mm = 45
# Cutting data (finishing in steel, the core's PRESET_CUTTING_DATA): flutes, cutting speed m/min, feed per
# tooth mm, the tool's top spindle speed 1/min.
settings.tool_flutes = 4
settings.tool_cutting_speed_m_min = 110.0
settings.tool_feed_per_tooth_mm = 0.02
settings.tool_max_rpm = 24000.0
