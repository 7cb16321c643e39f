# Flank Toolpath tool preset (Tool panel > Tool Presets): tapered end mill, taper 5 deg per side, tip diameter
# 6, flute length 20, shank diameter 10, overall length 70 mm (diameter at the top of the flutes 9.50 mm).
# Dimensions in mm and degrees: the *_mm / *_deg settings convert them to the scene's unit (a unit-less
# scene counts as mm), so the tool has the same size whatever the unit and unit scale.
import bpy
settings = bpy.context.scene.flank_settings

settings.tool_kind = 'CONE'
settings.sf_shape = 'alpha'
settings.tool_taper_deg = 5
settings.tool_tip_diameter_mm = 6
settings.tool_flute_length_mm = 20
settings.tool_shank_diameter_mm = 10
settings.tool_shank_length_mm = 50
# Cutting data (finishing in steel, the core's PRESET_CUTTING_DATA): flutes, cutting speed m/min, feed per
# tooth mm, the tool's top spindle speed 1/min.
settings.tool_flutes = 4
settings.tool_cutting_speed_m_min = 120.0
settings.tool_feed_per_tooth_mm = 0.03
settings.tool_max_rpm = 16000.0
